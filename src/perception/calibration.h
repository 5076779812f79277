// Hand-eye calibration from images of a ChArUco board (OpenCV's aruco and calib3d), as the
// source's M15 derives it: the robot moves, the camera sees the board, and AX = XB is solved for
// the unknown transform with each of OpenCV's five methods.
//   eye-in-hand: the camera rides on the gripper, the board stands still; X = T_gripper_camera.
//   eye-to-hand: the camera stands still, the board rides on the gripper; X = T_base_camera
//                (OpenCV's calibrateHandEye on the inverted gripper poses).
#pragma once
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/geometry.h"

namespace mm {

/// A ChArUco board: squares_x x squares_y chessboard squares with ArUco markers in the white ones.
struct CharucoBoardSpec {
  int squares_x = 7, squares_y = 5;
  double square = 0.04;   ///< [m] square side
  double marker = 0.03;   ///< [m] marker side
  /// The board's frame (OpenCV's object frame for it) in the frame of the face it is printed on
  /// (a box's +z face, the frame at the face's centre with the box's axes).
  Pose T_face_board() const;
  double width() const { return squares_x * square; }
  double height() const { return squares_y * square; }
  /// The printed texture: a square of this many squares' side (a power of two), the board
  /// centred on it with a white margin; the face it is printed on is that square.
  int textureSquares() const { return 8; }
  double faceSide() const { return textureSquares() * square; }
};

/// The board's texture, `px_per_square` pixels a square (a power of two), as a PNG: the board centred
/// on a white square of textureSquares() squares' side.
void writeBoardImage(const CharucoBoardSpec& board, const std::string& path, int px_per_square);
/// The board's inner chessboard corners in its frame, by id.
std::vector<Vec3> boardCorners(const CharucoBoardSpec& board);

struct BoardObservation {
  bool ok = false;
  std::string reason;
  std::vector<int> ids;                   ///< the corners found
  std::vector<Eigen::Vector2d> pixels;    ///< their sub-pixel positions
  Pose T_camera_board = Pose::Identity(); ///< from the corners (solvePnP on the known intrinsics)
  double reprojection_px = 0;             ///< RMS of that fit
};
/// Finds the board in an RGB frame (intrinsics from frame.camera, no distortion).
BoardObservation detectBoard(const Frame& frame, const CharucoBoardSpec& board);

/// OpenCV's hand-eye methods: Tsai, Park, Horaud, Andreff, Daniilidis.
const std::vector<std::string>& handEyeMethods();
/// Solves AX = XB with `method` from gripper poses in the base and board poses in the camera.
/// Eye-in-hand returns T_gripper_camera; eye-to-hand, T_base_camera.
Pose solveHandEye(const std::string& method, const std::vector<Pose>& T_base_gripper, const std::vector<Pose>& T_camera_board,
                  bool eye_in_hand);

/// The AX = XB residual over consecutive view pairs: A the gripper's motion, B the camera's (as the
/// board shows it), mean rotation [rad] and translation [m] of (AX)^-1 XB.
struct AxxbResidual {
  double rotation = 0, translation = 0;
};
AxxbResidual axxbResidual(const std::vector<Pose>& T_base_gripper, const std::vector<Pose>& T_camera_board, const Pose& X,
                          bool eye_in_hand);

/// Reads an extrinsics file written by `minimanip calibrate`: the camera's name and T_world_camera
/// (OpenCV's camera frame). Throws InputError naming the file.
Pose readExtrinsics(const std::string& path, std::string* camera);

}  // namespace mm
