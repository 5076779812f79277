#include "perception/calibration.h"

#include <opencv2/core/utility.hpp>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <stdexcept>

#include "core/error.h"

namespace mm {
namespace {

// OpenCV runs its parallel loops on TBB worker threads unless told otherwise. Library calls run in
// the calling thread here (docs/design/determinism.md); a worker thread alive at exit also crashed
// LeakSanitizer's end-of-process check now and then.
[[maybe_unused]] const int kOpenCvInCallingThread = (cv::setNumThreads(0), 0);

cv::Ptr<cv::aruco::CharucoBoard> makeBoard(const CharucoBoardSpec& b) {
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_5X5_100);
  return cv::aruco::CharucoBoard::create(b.squares_x, b.squares_y, static_cast<float>(b.square), static_cast<float>(b.marker), dict);
}

cv::Mat toCv(const Mat3& R) {
  cv::Mat m(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.at<double>(r, c) = R(r, c);
  return m;
}
cv::Mat toCv(const Vec3& t) { return (cv::Mat_<double>(3, 1) << t.x(), t.y(), t.z()); }
Pose fromCv(const cv::Mat& R, const cv::Mat& t) {
  Pose T = Pose::Identity();
  for (int r = 0; r < 3; ++r) {
    T.translation()[r] = t.at<double>(r);
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = R.at<double>(r, c);
  }
  return T;
}

}  // namespace

Pose CharucoBoardSpec::T_face_board() const {
  // OpenCV 4.6's ChArUco object frame has its origin at the board's top-left corner as drawn, x to
  // the right, y down the image and z into the board; MuJoCo maps a 2-D texture onto a box's +z
  // face with the image's top-left at the face's (-x, +y) corner (measured: the board's pose found
  // in renders, against the face's).
  return makePose(Vec3(-0.5 * width(), 0.5 * height(), 0), Mat3(Eigen::AngleAxisd(M_PI, Vec3::UnitX())));
}

void writeBoardImage(const CharucoBoardSpec& board, const std::string& path, int px) {
  // A power-of-two square canvas, the board centred on white: a renderer that resizes other sizes
  // to build its mipmaps would move the squares' edges by a fraction of a texel.
  cv::Mat drawn;
  makeBoard(board)->draw(cv::Size(board.squares_x * px, board.squares_y * px), drawn, 0, 1);
  const int side = board.textureSquares() * px;
  cv::Mat canvas(side, side, CV_8UC1, cv::Scalar(255));
  drawn.copyTo(canvas(cv::Rect((side - drawn.cols) / 2, (side - drawn.rows) / 2, drawn.cols, drawn.rows)));
  if (!cv::imwrite(path, canvas)) throw std::runtime_error("cannot write " + path);
}

std::vector<Vec3> boardCorners(const CharucoBoardSpec& board) {
  std::vector<Vec3> out;
  const cv::Ptr<cv::aruco::CharucoBoard> b = makeBoard(board);  // owns the corners the loop reads
  for (const cv::Point3f& p : b->chessboardCorners) out.emplace_back(p.x, p.y, p.z);
  return out;
}

BoardObservation detectBoard(const Frame& f, const CharucoBoardSpec& spec) {
  BoardObservation o;
  if (f.rgb.empty()) {
    o.reason = "no colour image";
    return o;
  }
  const cv::Mat rgb(f.camera.height, f.camera.width, CV_8UC3, const_cast<uint8_t*>(f.rgb.data()));
  cv::Mat grey;
  cv::cvtColor(rgb, grey, cv::COLOR_RGB2GRAY);
  const cv::Ptr<cv::aruco::CharucoBoard> board = makeBoard(spec);
  std::vector<int> marker_ids;
  std::vector<std::vector<cv::Point2f>> marker_corners;
  cv::aruco::detectMarkers(grey, board->dictionary, marker_corners, marker_ids);
  if (marker_ids.size() < 4) {
    o.reason = std::to_string(marker_ids.size()) + " markers found";
    return o;
  }
  const cv::Mat K = (cv::Mat_<double>(3, 3) << f.camera.fx, 0, f.camera.cx, 0, f.camera.fy, f.camera.cy, 0, 0, 1);
  const cv::Mat dist = cv::Mat::zeros(1, 5, CV_64F);
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, grey, board, corners, ids, K, dist);
  if (ids.size() < 6) {
    o.reason = std::to_string(ids.size()) + " chessboard corners found";
    return o;
  }
  // OpenCV 4.6's ChArUco corners come out half a pixel right of and below the convention the rest
  // of OpenCV and our camera model use (a pixel's centre at integer coordinates): on OpenCV's own
  // drawing of the board, a corner on the boundary between pixels 219 and 220 is reported at 220.0,
  // where findChessboardCorners + cornerSubPix put the same kind of corner at 219.5 (measured).
  for (cv::Point2f& c : corners) c -= cv::Point2f(0.5f, 0.5f);
  cv::Mat rvec, tvec;
  if (!cv::aruco::estimatePoseCharucoBoard(corners, ids, board, K, dist, rvec, tvec)) {
    o.reason = "no board pose from the corners";
    return o;
  }
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  o.T_camera_board = fromCv(R, tvec);
  std::vector<cv::Point3f> object;
  for (int id : ids) object.push_back(board->chessboardCorners[static_cast<size_t>(id)]);
  std::vector<cv::Point2f> projected;
  cv::projectPoints(object, rvec, tvec, K, dist, projected);
  double sum = 0;
  for (size_t i = 0; i < ids.size(); ++i) {
    o.ids.push_back(ids[i]);
    o.pixels.emplace_back(corners[i].x, corners[i].y);
    sum += std::pow(cv::norm(projected[i] - corners[i]), 2);
  }
  o.reprojection_px = std::sqrt(sum / static_cast<double>(ids.size()));
  o.ok = true;
  return o;
}

const std::vector<std::string>& handEyeMethods() {
  static const std::vector<std::string> names = {"Tsai", "Park", "Horaud", "Andreff", "Daniilidis"};
  return names;
}

Pose solveHandEye(const std::string& method, const std::vector<Pose>& T_base_gripper, const std::vector<Pose>& T_camera_board,
                  bool eye_in_hand) {
  static const std::vector<cv::HandEyeCalibrationMethod> ids = {cv::CALIB_HAND_EYE_TSAI, cv::CALIB_HAND_EYE_PARK, cv::CALIB_HAND_EYE_HORAUD,
                                                               cv::CALIB_HAND_EYE_ANDREFF, cv::CALIB_HAND_EYE_DANIILIDIS};
  size_t m = 0;
  while (m < handEyeMethods().size() && handEyeMethods()[m] != method) ++m;
  if (m == handEyeMethods().size()) throw std::invalid_argument("unknown hand-eye method " + method);
  std::vector<cv::Mat> Rg, tg, Rt, tt;
  for (size_t i = 0; i < T_base_gripper.size(); ++i) {
    // Eye-to-hand: the inverted gripper poses make OpenCV's output the camera in the base.
    const Pose G = eye_in_hand ? T_base_gripper[i] : Pose(T_base_gripper[i].inverse());
    Rg.push_back(toCv(Mat3(G.linear())));
    tg.push_back(toCv(Vec3(G.translation())));
    Rt.push_back(toCv(Mat3(T_camera_board[i].linear())));
    tt.push_back(toCv(Vec3(T_camera_board[i].translation())));
  }
  cv::Mat R, t;
  cv::calibrateHandEye(Rg, tg, Rt, tt, R, t, ids[m]);
  return fromCv(R, t);
}

AxxbResidual axxbResidual(const std::vector<Pose>& G, const std::vector<Pose>& C, const Pose& X, bool eye_in_hand) {
  AxxbResidual r;
  int n = 0;
  for (size_t i = 0; i + 1 < G.size(); ++i) {
    const size_t j = i + 1;
    const Pose A = eye_in_hand ? Pose(G[j].inverse() * G[i]) : Pose(G[j] * G[i].inverse());
    const Pose B = C[j] * C[i].inverse();
    const Pose E = (A * X).inverse() * (X * B);
    r.rotation += Eigen::AngleAxisd(E.linear()).angle();
    r.translation += E.translation().norm();
    ++n;
  }
  if (n) r.rotation /= n, r.translation /= n;
  return r;
}

Pose readExtrinsics(const std::string& path, std::string* camera) {
  YAML::Node n;
  try {
    n = YAML::LoadFile(path);
  } catch (const YAML::Exception& ex) {
    throw InputError(path, std::string("cannot read the extrinsics: ") + ex.what());
  }
  if (!n["position"] || !n["quaternion_wxyz"] || n["position"].size() != 3 || n["quaternion_wxyz"].size() != 4)
    throw InputError(path, "expected position: [x, y, z] and quaternion_wxyz: [w, x, y, z] (written by minimanip calibrate)");
  const Vec3 p(n["position"][0].as<double>(), n["position"][1].as<double>(), n["position"][2].as<double>());
  Quat q(n["quaternion_wxyz"][0].as<double>(), n["quaternion_wxyz"][1].as<double>(), n["quaternion_wxyz"][2].as<double>(),
         n["quaternion_wxyz"][3].as<double>());
  if (!p.allFinite() || !q.coeffs().allFinite() || std::abs(q.norm() - 1) > 1e-3)
    throw InputError(path, "the position must be finite and the quaternion a unit one");
  if (camera) *camera = n["camera"] ? n["camera"].as<std::string>() : "";
  return makePose(p, q.normalized());
}

}  // namespace mm
