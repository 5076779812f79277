// The external components' protocol, version 1: the request line, answers in the camera's or the
// world's frame read into the world, everything that is not the protocol refused with its reason,
// and the images as .npy files that NumPy itself reads.
#include "perception/external_protocol.h"

#include "core/utf8.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace mm {
namespace {

namespace fs = std::filesystem;
using testing::HasSubstr;

ExternalRequest request() {
  ExternalRequest r;
  r.id = 7;
  r.trial = 3;
  r.seed = 1;
  r.depth = "/dev/shm/view/depth.npy";
  r.camera.width = 640;
  r.camera.height = 480;
  r.camera.fx = r.camera.fy = 600;
  r.camera.cx = 319.5;
  r.camera.cy = 239.5;
  // Looking straight down from 1.2 m: the camera's z is the world's -z, its x the world's x.
  r.camera.T_world_camera = makePose(Vec3(0.5, 0.0, 1.2), rotX(M_PI));
  r.T_world_region = makePose(Vec3(0.5, 0.0, 0.02), Mat3::Identity());
  r.region_half = Vec3(0.15, 0.2, 0.1);
  return r;
}

std::string pose(const Pose& T) {
  std::ostringstream s;
  s.precision(17);
  s << '[';
  for (int r = 0; r < 4; ++r) {
    s << (r ? ",[" : "[");
    for (int c = 0; c < 4; ++c) s << (c ? "," : "") << T.matrix()(r, c);
    s << ']';
  }
  s << ']';
  return s.str();
}

TEST(ExternalProtocol, TheRequestSaysEverythingADetectorNeeds) {
  const ExternalRequest r = request();
  const nlohmann::json j = nlohmann::json::parse(requestLine(r));
  EXPECT_EQ(j["protocol"], 1);
  EXPECT_EQ(j["id"], 7);
  EXPECT_EQ(j["want"], "grasps");
  EXPECT_EQ(j["trial"], 3);
  EXPECT_EQ(j["seed"], 1);
  EXPECT_EQ(j["images"]["depth"], "/dev/shm/view/depth.npy");
  EXPECT_TRUE(j["images"]["rgb"].is_null());
  EXPECT_TRUE(j["images"]["labels"].is_null());
  EXPECT_TRUE(j["oracle"].is_null());
  EXPECT_EQ(j["camera"]["width"], 640);
  EXPECT_DOUBLE_EQ(j["camera"]["cx"].get<double>(), 319.5);
  EXPECT_DOUBLE_EQ(j["camera"]["T_world_camera"][2][3].get<double>(), 1.2);
  EXPECT_DOUBLE_EQ(j["camera"]["T_world_camera"][1][1].get<double>(), -1.0);
  EXPECT_DOUBLE_EQ(j["region"]["half_extents"][1].get<double>(), 0.2);
  EXPECT_DOUBLE_EQ(j["gripper"]["stroke"].get<double>(), 0.08);
  EXPECT_DOUBLE_EQ(j["gripper"]["finger_margin"].get<double>(), 0.012);
  EXPECT_EQ(requestLine(r).find('\n'), std::string::npos) << "one line";
}

TEST(ExternalProtocol, GraspsInTheCamerasFrameAreReadIntoTheWorld) {
  const ExternalRequest r = request();
  // A grasp 1.1 m in front of the camera, its approach along the camera's z: straight down in the world.
  const Pose T_camera_tcp = makePose(Vec3(0.01, 0.02, 1.1), Mat3::Identity());
  ExternalAnswer a;
  std::string why;
  ASSERT_TRUE(parseAnswer(R"({"protocol": 1, "id": 7, "frame": "camera", "grasps": [{"T": )" + pose(T_camera_tcp) +
                              R"(, "opening": 0.05, "score": 0.9, "note": "ignored"}]})",
                          r, a, why))
      << why;
  ASSERT_EQ(a.grasps.size(), 1u);
  EXPECT_TRUE(a.grasps[0].T_world_tcp.translation().isApprox(Vec3(0.51, -0.02, 0.1), 1e-9));
  EXPECT_TRUE(a.grasps[0].T_world_tcp.linear().col(2).isApprox(-Vec3::UnitZ(), 1e-9));
  EXPECT_DOUBLE_EQ(a.grasps[0].opening, 0.05);
  EXPECT_DOUBLE_EQ(a.grasps[0].score, 0.9);
  // The same grasp said in the world's frame.
  ASSERT_TRUE(parseAnswer(R"({"protocol": 1, "id": 7, "frame": "world", "grasps": [{"T": )" +
                              pose(r.camera.T_world_camera * T_camera_tcp) + R"(, "opening": 0.05, "score": 0.9}]})",
                          r, a, why))
      << why;
  ASSERT_EQ(a.grasps.size(), 1u);
  EXPECT_TRUE(a.grasps[0].T_world_tcp.isApprox(r.camera.T_world_camera * T_camera_tcp, 1e-9));
  // Nothing found is an empty list; the child's own failure is its error.
  ASSERT_TRUE(parseAnswer(R"({"protocol": 1, "id": 7, "frame": "world", "grasps": []})", r, a, why)) << why;
  EXPECT_TRUE(a.grasps.empty());
  ASSERT_TRUE(parseAnswer(R"({"protocol": 1, "id": 7, "error": "CUDA out of memory"})", r, a, why)) << why;
  EXPECT_EQ(a.error, "CUDA out of memory");
}

TEST(ExternalProtocol, ObjectPosesAreReadWhenTheRequestWantsThem) {
  ExternalRequest r = request();
  r.want = ExternalWant::kObjects;
  ExternalAnswer a;
  std::string why;
  const Pose T = makePose(Vec3(0.4, 0.1, 0.05), rotZ(0.3));
  ASSERT_TRUE(parseAnswer(R"({"protocol": 1, "id": 7, "frame": "world", "objects": [{"name": "bolt", "T": )" + pose(T) +
                              R"(, "score": 0.7}]})",
                          r, a, why))
      << why;
  ASSERT_EQ(a.objects.size(), 1u);
  EXPECT_EQ(a.objects[0].name, "bolt");
  EXPECT_TRUE(a.objects[0].T_world_object.isApprox(T, 1e-6));
}

TEST(ExternalProtocol, WhatIsNotTheProtocolIsRefusedWithItsReason) {
  const ExternalRequest r = request();
  const std::string good_T = pose(makePose(Vec3(0, 0, 1), Mat3::Identity()));
  auto why = [&](const std::string& line) {
    ExternalAnswer a;
    std::string reason;
    return parseAnswer(line, r, a, reason) ? std::string("(accepted)") : reason;
  };
  auto grasp = [&](const std::string& fields) {
    return why(R"({"protocol": 1, "id": 7, "frame": "camera", "grasps": [{)" + fields + "}]}");
  };
  EXPECT_THAT(why("Loading model weights..."), HasSubstr("not JSON"));
  EXPECT_THAT(why("[1, 2]"), HasSubstr("not a JSON object"));
  EXPECT_THAT(why(R"({"id": 7, "frame": "camera", "grasps": []})"), HasSubstr("\"protocol\" is missing"));
  EXPECT_THAT(why(R"({"protocol": 2, "id": 7, "frame": "camera", "grasps": []})"), HasSubstr("\"protocol\" is 2, expected 1"));
  EXPECT_THAT(why(R"({"protocol": 1, "id": 6, "frame": "camera", "grasps": []})"), HasSubstr("answers request 6, expected 7"));
  EXPECT_THAT(why(R"({"protocol": 1, "id": 7, "frame": "base_link", "grasps": []})"), HasSubstr("expected \"camera\" or \"world\""));
  EXPECT_THAT(why(R"({"protocol": 1, "id": 7, "grasps": []})"), HasSubstr("\"frame\" is missing"));
  EXPECT_THAT(why(R"({"protocol": 1, "id": 7, "frame": "camera"})"), HasSubstr("\"grasps\" is missing"));
  EXPECT_THAT(why(R"({"protocol": 1, "id": 7, "error": ""})"), HasSubstr("\"error\" is not a non-empty string"));
  EXPECT_THAT(grasp(R"("opening": 0.05, "score": 1)"), HasSubstr("grasps[0]: not an object with \"T\""));
  EXPECT_THAT(grasp(R"("T": [[1,0,0],[0,1,0],[0,0,1]], "opening": 0.05, "score": 1)"), HasSubstr("not a 4 x 4 matrix"));
  EXPECT_THAT(grasp(R"("T": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "opening": 0.05, "score": 1)"), HasSubstr("not a rotation"));
  EXPECT_THAT(grasp(R"("T": [[-1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "opening": 0.05, "score": 1)"), HasSubstr("not a rotation"));
  EXPECT_THAT(grasp(R"("T": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]], "opening": 0.05, "score": 1)"), HasSubstr("last row"));
  EXPECT_THAT(grasp(R"("T": [[1,0,0,NaN],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "opening": 0.05, "score": 1)"), HasSubstr("not JSON"));
  EXPECT_THAT(grasp(R"("T": [[1,0,0,"a"],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "opening": 0.05, "score": 1)"), HasSubstr("not a finite number"));
  EXPECT_THAT(grasp(R"("T": [[1,0,0,1e300],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "opening": 0.05, "score": 1)"), HasSubstr("more than 100 m away"));
  EXPECT_THAT(grasp(R"("T": )" + good_T + R"(, "opening": 0.2, "score": 1)"), HasSubstr("expected (0, 0.08]"));
  EXPECT_THAT(grasp(R"("T": )" + good_T + R"(, "opening": 0, "score": 1)"), HasSubstr("\"opening\" is 0"));
  EXPECT_THAT(grasp(R"("T": )" + good_T + R"(, "score": 1)"), HasSubstr("\"opening\" is missing"));
  EXPECT_THAT(grasp(R"("T": )" + good_T + R"(, "opening": 0.05)"), HasSubstr("\"score\" is missing"));
  EXPECT_EQ(grasp(R"("T": )" + good_T + R"(, "opening": 0.05, "score": 1)"), "(accepted)");
  // A flood of entries; the start of a line that is not even UTF-8, quoted as valid UTF-8.
  std::string flood = R"({"protocol": 1, "id": 7, "frame": "camera", "grasps": [)";
  for (int k = 0; k <= 10000; ++k) flood += std::string(k ? "," : "") + "0";
  EXPECT_THAT(why(flood + "]}"), HasSubstr("has 10001 entries, more than 10000"));
  const std::string not_utf8 = why("\xff\xfe progress 10%");
  EXPECT_THAT(not_utf8, HasSubstr("not JSON"));
  EXPECT_EQ(escapeInvalidUtf8(not_utf8), not_utf8) << "valid UTF-8 already";
}

// NumPy's own loader reads what writeNpy writes: shape, dtype and every value.
TEST(ExternalProtocol, TheImagesAreNpyFilesThatNumPyReads) {
  const char* python = "/usr/bin/python3";  // Debian's, with python3-numpy (tools/setup --tests)
  ASSERT_EQ(access(python, X_OK), 0) << "no " << python;
  const fs::path dir = fs::temp_directory_path() / ("mm_npy_" + std::to_string(getpid()));
  fs::create_directories(dir);
  // Sizes that put the data at each of several header paddings.
  for (const auto& [h, w] : {std::pair{480, 640}, std::pair{3, 5}, std::pair{1, 1}, std::pair{961, 1281}}) {
    std::vector<float> depth(static_cast<size_t>(h * w));
    std::vector<uint8_t> rgb(static_cast<size_t>(h * w * 3));
    for (size_t i = 0; i < depth.size(); ++i) depth[i] = i % 7 == 0 ? 0.0f : 0.5f + 0.0009765625f * static_cast<float>(i % 1000);  // exact in float
    for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<uint8_t>((i * 31) % 256);
    writeNpy(dir / "depth.npy", "<f4", {static_cast<size_t>(h), static_cast<size_t>(w)}, depth.data(), depth.size() * sizeof(float));
    writeNpy(dir / "rgb.npy", "|u1", {static_cast<size_t>(h), static_cast<size_t>(w), 3}, rgb.data(), rgb.size());
    // The format's own rule, which numpy.load does not check: the data starts on a multiple of 64,
    // after a header ending in a newline.
    for (const char* name : {"depth.npy", "rgb.npy"}) {
      std::ifstream in(dir / name, std::ios::binary);
      std::string head(10, '\0');
      in.read(head.data(), 10);
      const size_t header = static_cast<uint8_t>(head[8]) | static_cast<size_t>(static_cast<uint8_t>(head[9])) << 8;
      EXPECT_EQ(head.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
      EXPECT_EQ((10 + header) % 64, 0u) << name;
      std::string dict(header, '\0');
      in.read(dict.data(), static_cast<std::streamsize>(header));
      EXPECT_EQ(dict.back(), '\n') << name;
    }
    const std::string script =
        "import numpy as np, sys; d = np.load(sys.argv[1]); c = np.load(sys.argv[2]); "
        "i = np.arange(d.size); want = np.where(i % 7 == 0, 0.0, 0.5 + 0.0009765625 * (i % 1000)).astype(np.float32).reshape(d.shape); "
        "j = np.arange(c.size); "
        "print(d.dtype, d.shape, c.dtype, c.shape, bool((d == want).all()), bool((c.ravel() == (j * 31) % 256).all()))";
    const std::string cmd = std::string(python) + " -c '" + script + "' " + (dir / "depth.npy").string() + " " + (dir / "rgb.npy").string();
    FILE* p = popen(cmd.c_str(), "r");
    ASSERT_NE(p, nullptr);
    std::array<char, 512> buf{};
    std::string out;
    while (fgets(buf.data(), buf.size(), p)) out += buf.data();
    ASSERT_EQ(pclose(p), 0) << cmd << "\n" << out;
    EXPECT_EQ(out, "float32 (" + std::to_string(h) + ", " + std::to_string(w) + ") uint8 (" + std::to_string(h) + ", " + std::to_string(w) +
                       ", 3) True True\n");
  }
  EXPECT_THROW(writeNpy(dir / "short.npy", "<f4", {2, 3}, nullptr, 20), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir / "short.npy"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mm
