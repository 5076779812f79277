// `minimanip dataset`: a pile campaign's camera views as a BOP dataset. Its files are checked
// against the format's published field list and units (bop_toolkit's docs/bop_datasets_format.md),
// and each object's true pose, projected with the written intrinsics, draws the written model onto
// its written mask to within a pixel.
#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "../campaign/cli_helpers.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

json readJson(const fs::path& p) {
  std::ifstream in(p);
  EXPECT_TRUE(in.good()) << p;
  return json::parse(in);
}

// An ASCII PLY of ours: vertices (x y z first) and triangles.
struct Ply {
  std::vector<std::array<double, 3>> v;
  std::vector<std::array<int, 3>> f;
};
Ply readPly(const fs::path& p) {
  std::ifstream in(p);
  Ply out;
  std::string line;
  size_t nv = 0, nf = 0;
  std::getline(in, line);
  EXPECT_EQ(line, "ply") << p;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream s(line);
    std::string a, b;
    size_t n = 0;
    s >> a >> b >> n;
    if (a == "element" && b == "vertex") nv = n;
    if (a == "element" && b == "face") nf = n;
  }
  for (size_t i = 0; i < nv && std::getline(in, line); ++i) {
    std::istringstream s(line);
    std::array<double, 3> x{};
    s >> x[0] >> x[1] >> x[2];
    out.v.push_back(x);
  }
  for (size_t i = 0; i < nf && std::getline(in, line); ++i) {
    std::istringstream s(line);
    int k = 0;
    std::array<int, 3> t{};
    s >> k >> t[0] >> t[1] >> t[2];
    EXPECT_EQ(k, 3);
    out.f.push_back(t);
  }
  EXPECT_EQ(out.v.size(), nv);
  EXPECT_EQ(out.f.size(), nf);
  return out;
}

void expectNumbers(const json& j, size_t n, const std::string& what) {
  ASSERT_TRUE(j.is_array()) << what;
  ASSERT_EQ(j.size(), n) << what;
  for (const json& x : j) EXPECT_TRUE(x.is_number()) << what;
}

// Checks the dataset at `bop` (its first scene: `views` images, at least `min_objects` objects in
// them, at least `min_symmetries` declared symmetries over its models).
void expectBopDataset(const fs::path& bop, int views, int min_objects, int min_symmetries) {
  EXPECT_TRUE(fs::exists(bop / "minimanip_dataset.json"));

  const json camera = readJson(bop / "camera.json");
  for (const char* k : {"cx", "cy", "fx", "fy", "width", "height", "depth_scale"}) EXPECT_TRUE(camera[k].is_number()) << k;
  const json info = readJson(bop / "models" / "models_info.json");
  ASSERT_FALSE(info.empty());
  std::map<int, Ply> models;
  int symmetric = 0;
  for (const auto& [id, m] : info.items()) {
    for (const char* k : {"diameter", "min_x", "min_y", "min_z", "size_x", "size_y", "size_z"}) EXPECT_TRUE(m[k].is_number()) << id << " " << k;
    // Millimetres: a generated object is a few centimetres across.
    EXPECT_GT(m["diameter"].get<double>(), 20) << id;
    EXPECT_LT(m["diameter"].get<double>(), 300) << id;
    char name[32];
    std::snprintf(name, sizeof name, "obj_%06d.ply", std::stoi(id));
    const Ply& ply = models[std::stoi(id)] = readPly(bop / "models" / name);
    // Each declared symmetry maps the model's surface onto itself (its vertices onto its vertices).
    for (const json& S : m.value("symmetries_discrete", json::array())) {
      ASSERT_EQ(S.size(), 16u) << id;
      for (const auto& p : ply.v) {
        double best = 1e9;
        const std::array<double, 3> q = {S[0].get<double>() * p[0] + S[1].get<double>() * p[1] + S[2].get<double>() * p[2] + S[3].get<double>(),
                                         S[4].get<double>() * p[0] + S[5].get<double>() * p[1] + S[6].get<double>() * p[2] + S[7].get<double>(),
                                         S[8].get<double>() * p[0] + S[9].get<double>() * p[1] + S[10].get<double>() * p[2] + S[11].get<double>()};
        for (const auto& r : ply.v) best = std::min(best, std::hypot(q[0] - r[0], q[1] - r[1], q[2] - r[2]));
        ASSERT_LT(best, 0.01) << id << ": a symmetry maps a vertex off the surface's vertices (mm)";
      }
      ++symmetric;
    }
  }

  EXPECT_GE(symmetric, min_symmetries);
  const fs::path scene = bop / "train" / "000000";
  const json cams = readJson(scene / "scene_camera.json"), gts = readJson(scene / "scene_gt.json"),
             infos = readJson(scene / "scene_gt_info.json");
  ASSERT_EQ(cams.size(), static_cast<size_t>(views));
  int checked = 0;
  for (const auto& [im, cam] : cams.items()) {
    expectNumbers(cam["cam_K"], 9, "cam_K");
    expectNumbers(cam["cam_R_w2c"], 9, "cam_R_w2c");
    expectNumbers(cam["cam_t_w2c"], 3, "cam_t_w2c");
    EXPECT_DOUBLE_EQ(cam["depth_scale"].get<double>(), 0.1) << "a depth PNG's unit: 0.1 mm";
    char name[32];
    std::snprintf(name, sizeof name, "%06d", std::stoi(im));
    const cv::Mat rgb = cv::imread((scene / "rgb" / (std::string(name) + ".png")).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat depth = cv::imread((scene / "depth" / (std::string(name) + ".png")).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(rgb.type(), CV_8UC3);
    ASSERT_EQ(depth.type(), CV_16UC1);
    EXPECT_EQ(rgb.cols, camera["width"].get<int>());
    EXPECT_EQ(rgb.rows, camera["height"].get<int>());
    const std::vector<double> K = cam["cam_K"].get<std::vector<double>>();
    const json& gt = gts[im];
    const json& gi = infos[im];
    ASSERT_EQ(gt.size(), gi.size());
    EXPECT_GE(gt.size(), 1u) << "the pile is in view";
    for (size_t g = 0; g < gt.size(); ++g) {
      const int obj = gt[g]["obj_id"].get<int>();
      ASSERT_TRUE(models.count(obj)) << obj;
      expectNumbers(gt[g]["cam_R_m2c"], 9, "cam_R_m2c");
      expectNumbers(gt[g]["cam_t_m2c"], 3, "cam_t_m2c");
      const std::vector<double> R = gt[g]["cam_R_m2c"].get<std::vector<double>>(), t = gt[g]["cam_t_m2c"].get<std::vector<double>>();
      EXPECT_GT(t[2], 300) << "millimetres: the bin is most of a metre from the camera";
      EXPECT_LT(t[2], 3000);
      for (const char* k : {"bbox_obj", "bbox_visib"}) expectNumbers(gi[g][k], 4, k);
      char file[64];
      std::snprintf(file, sizeof file, "%s_%06zu.png", name, g);
      const cv::Mat mask = cv::imread((scene / "mask" / file).string(), cv::IMREAD_UNCHANGED);
      const cv::Mat visib = cv::imread((scene / "mask_visib" / file).string(), cv::IMREAD_UNCHANGED);
      ASSERT_EQ(mask.type(), CV_8UC1) << file;
      ASSERT_EQ(visib.type(), CV_8UC1) << file;
      EXPECT_EQ(cv::countNonZero(mask), gi[g]["px_count_all"].get<int>()) << file;
      EXPECT_EQ(cv::countNonZero(visib), gi[g]["px_count_visib"].get<int>()) << file;
      EXPECT_EQ(cv::countNonZero(visib & ~mask), 0) << file << ": what is seen of an object is in its silhouette";
      EXPECT_NEAR(gi[g]["visib_fract"].get<double>(), double(cv::countNonZero(visib)) / cv::countNonZero(mask), 1e-9);
      // The model drawn at its pose with the written intrinsics (triangles filled, 1/256 px).
      cv::Mat drawn = cv::Mat::zeros(mask.size(), CV_8UC1);
      const Ply& m = models[obj];
      for (const auto& f : m.f) {
        std::vector<cv::Point> tri;
        for (int k : f) {
          const auto& p = m.v[static_cast<size_t>(k)];
          const double x = R[0] * p[0] + R[1] * p[1] + R[2] * p[2] + t[0], y = R[3] * p[0] + R[4] * p[1] + R[5] * p[2] + t[1],
                       z = R[6] * p[0] + R[7] * p[1] + R[8] * p[2] + t[2];
          tri.emplace_back(cvRound(256 * (K[0] * x / z + K[2])), cvRound(256 * (K[4] * y / z + K[5])));
        }
        cv::fillConvexPoly(drawn, tri, cv::Scalar(255), cv::LINE_8, 8);
      }
      // Agreement to a pixel: each silhouette within the other grown by one pixel.
      cv::Mat grown_mask, grown_drawn;
      cv::dilate(mask, grown_mask, cv::Mat::ones(3, 3, CV_8UC1));
      cv::dilate(drawn, grown_drawn, cv::Mat::ones(3, 3, CV_8UC1));
      EXPECT_EQ(cv::countNonZero(drawn & ~grown_mask), 0) << file << ": the model drawn outside its mask grown by a pixel";
      EXPECT_EQ(cv::countNonZero(mask & ~grown_drawn), 0) << file << ": the mask outside the model drawn, grown by a pixel";
      EXPECT_GT(cv::countNonZero(mask), 50) << file;
      ++checked;
    }
  }
  EXPECT_GE(checked, min_objects);
}

TEST(Dataset, APileCampaignsViewsAreABopDatasetWhosePosesDrawTheirModelsOntoTheirMasks) {
  testing_cli::TempDir dir;
  const std::string run = (dir.path() / "run").string();
  const auto r = testing_cli::runMinimanip(
      "run experiments/clutter_pile.yaml --trials 1 --jobs 1 --set progress=none --set perception.mode=camera "
      "--set tree=experiments/trees/clutter_removal_cloud.xml --set objects.count_min=4 --set objects.count_max=4 --out " + run);
  ASSERT_EQ(r.code, 0) << r.out;
  const auto d = testing_cli::runMinimanip("dataset " + run + " --views 3");
  ASSERT_EQ(d.code, 0) << d.out;
  EXPECT_NE(d.out.find("3 views"), std::string::npos) << d.out;
  EXPECT_NE(d.out.find("matches its line"), std::string::npos) << d.out;
  expectBopDataset(fs::path(run) / "bop", 3, 6, 0);
  // Written again over itself; a folder of something else is refused and left as it was.
  EXPECT_EQ(testing_cli::runMinimanip("dataset " + run + " --views 1").code, 0);
  const fs::path other = dir.path() / "other";
  fs::create_directories(other / "models");
  std::ofstream(other / "mine.txt") << "keep";
  const auto refused = testing_cli::runMinimanip("dataset " + run + " --views 1 --out " + other.string());
  EXPECT_EQ(refused.code, 2) << refused.out;
  EXPECT_TRUE(fs::exists(other / "mine.txt"));
}

TEST(Dataset, CatalogueBoxesAndCylindersHaveTheirShapesAndSymmetries) {
  testing_cli::TempDir dir;
  const std::string run = (dir.path() / "run").string();
  const auto r = testing_cli::runMinimanip("run experiments/mixed_shapes.yaml --trials 1 --jobs 1 --set progress=none "
                                           "--set perception.mode=camera --out " + run);
  ASSERT_EQ(r.code, 0) << r.out;
  const auto d = testing_cli::runMinimanip("dataset " + run + " --views 1");
  ASSERT_EQ(d.code, 0) << d.out;
  expectBopDataset(fs::path(run) / "bop", 1, 3, 3);
}

TEST(Dataset, MeshKindsDeclaredSymmetriesAreInModelsInfo) {
  // known_objects.yaml's kinds: the hex bar (a group of 12), the chamfered block (2) and the frustum
  // (4) declare theirs; ten objects of five kinds, dropped, put most of them in the first view.
  testing_cli::TempDir dir;
  const std::string run = (dir.path() / "run").string();
  const auto r = testing_cli::runMinimanip("run experiments/known_objects.yaml --trials 1 --jobs 1 --set progress=none "
                                           "--set objects.count_min=10 --set objects.count_max=10 --out " + run);
  ASSERT_EQ(r.code, 0) << r.out;
  const auto d = testing_cli::runMinimanip("dataset " + run + " --views 1");
  ASSERT_EQ(d.code, 0) << d.out;
  expectBopDataset(fs::path(run) / "bop", 1, 5, 3);
}

TEST(Dataset, ACampaignWithoutCameraImagesIsExitTwo) {
  testing_cli::TempDir dir;
  const std::string run = (dir.path() / "run").string();
  const auto r = testing_cli::runMinimanip("run experiments/quickstart.yaml --trials 1 --jobs 1 --set progress=none --out " + run);
  ASSERT_EQ(r.code, 0) << r.out;
  const auto d = testing_cli::runMinimanip("dataset " + run);
  EXPECT_EQ(d.code, 2) << d.out;
  EXPECT_NE(d.out.find("takes no camera image"), std::string::npos) << d.out;
  EXPECT_FALSE(fs::exists(fs::path(run) / "bop"));
}

}  // namespace
}  // namespace mm
