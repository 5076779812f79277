// Known objects' 6D poses in a depth view, from their models (CAD meshes), in three steps:
//   hypotheses  point-pair features (Drost, Ulrich, Navab, Ilic, "Model Globally, Match Locally:
//               Efficient and Robust 3D Object Recognition", CVPR 2010) of each model voted over
//               one segment's points, the votes clustered up to the model's symmetries; our own
//               (OpenCV contrib's surface_matching trains a 2,400-point model in 48 s here, and
//               clusters with no symmetries: docs/design/pose-estimation.md); and each model's
//               plane faces laid on the segment's largest plane, their smallest rectangles on
//               its (a face seen whole: its point pairs all look alike and locate nothing);
//   refinement  each hypothesis aligned to the segment's points by point-to-plane ICP with
//               projective association (the model drawn at the pose: each pixel's observed point
//               paired with the model's surface at that pixel; Rusinkiewicz and Levoy, "Efficient
//               Variants of the ICP Algorithm", 3DIM 2001);
//   verification the model drawn where the refined pose puts it (a CPU z-buffer of its triangles)
//               against what the camera saw: pixels where the drawn and seen depths agree, where
//               the camera sees past the model or the segment shows what the model does not cover
//               (both contradict the pose), and where something else stands in front (no evidence).
// The best-verified pose of any model wins; a segment no model explains well enough keeps no pose
// (it stays an unknown object). A whole view (estimateView) is posed segment by segment, each
// pose's pixels its own, what it leaves of its segment posed again (objects merged in one segment). Reads only the frame's depth and camera and the segment's pixels
// and points: nothing of the simulator. One thread; the same input gives the same pose.
#pragma once
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/geometry.h"
#include "core/symmetry.h"
#include "perception/segmentation.h"

namespace mm {

/// A known object's model: its surface in the object's frame, and its symmetries.
struct ObjectModel {
  std::string name;
  std::vector<Vec3> vertices;               ///< [m] the object's frame
  std::vector<std::array<int, 3>> faces;    ///< triangles, outward by the right-hand rule
  std::vector<Mat3> symmetries{Mat3::Identity()};  ///< the rotations mapping it onto itself: a group, identity first
  double diameter = 0;                      ///< [m] the largest distance between two of its vertices
  // What the robot knows of the kind besides its surface (its item master data): to plan and grasp
  // with the object once posed.
  std::shared_ptr<const std::vector<ConvexPiece>> pieces;  ///< collision: its convex pieces, the object's frame
  Vec3 half_size = Vec3::Zero();            ///< [m] its pieces' bounding box
  double mass = 0;                          ///< [kg]

  /// A model of the triangles given (turned outward if the mesh's signed volume is negative), its
  /// diameter computed; `generators` closed into their group (core/symmetry.h).
  static ObjectModel fromMesh(std::string name, std::vector<Vec3> vertices, std::vector<std::array<int, 3>> faces,
                              const std::vector<Mat3>& generators = {});
};

/// BOP's pose errors (Hodaň et al., "BOP Challenge 2020 on 6D Object Localization", ECCVW 2020):
/// MSSD [m], the largest distance of a model vertex between the two poses, minimised over the
/// model's symmetries; MSPD [px], the same of their projections into `cam`'s image.
double mssd(const ObjectModel& m, const Pose& estimate, const Pose& truth);
double mspd(const ObjectModel& m, const Pose& estimate, const Pose& truth, const CameraModel& cam);

/// BOP's VSD (Hodaň, Michel et al., ECCV 2018; as bop_toolkit's pose_error.vsd with the "step"
/// cost and the "bop19" visibility): the model drawn at both poses as distance images (along each
/// pixel's ray), each pose's visible surface found against the view's `depth` (tolerance `delta`
/// [m]; missing depth counts as visible; the estimate also visible where the truth is), and for
/// each tau of `taus` (a share of the diameter) the union's share where the two surfaces are not
/// both visible and within tau of each other. 1 where nothing of either is visible.
std::vector<double> vsd(const ObjectModel& m, const Pose& estimate, const Pose& truth, const CameraModel& cam,
                        const std::vector<float>& depth, double delta, const std::vector<double>& taus);

/// The model alone drawn at `T_world_object` into `cam`'s image, over the pixels [u0, u1) x [v0, v1):
/// depth [m] (0 where it does not cover) and the face seen at each pixel (-1: none), row-major
/// over the window. Back faces are culled; the nearest face wins.
struct ModelDrawing {
  int u0 = 0, v0 = 0, width = 0, height = 0;
  std::vector<float> depth;
  std::vector<int> face;
  float at(int u, int v) const { return depth[static_cast<size_t>(v - v0) * width + (u - u0)]; }
};
ModelDrawing drawModel(const ObjectModel& m, const Pose& T_world_object, const CameraModel& cam, int u0, int v0, int u1, int v1);
/// The pixel window the model covers at `T_world_object` (its vertices' projections, a pixel of
/// margin), clipped to the image (else to twice its size beyond each edge); empty (u1 <= u0) when
/// it is not in front of the camera.
std::array<int, 4> modelWindow(const ObjectModel& m, const Pose& T_world_object, const CameraModel& cam, bool clip = true);

struct ModelPoseOptions {
  // Point-pair features (lengths relative to each model's diameter).
  double model_sampling = 0.04;   ///< the model's points thinned to this spacing
  double distance_step = 0.05;    ///< the pair distance's bin
  int angle_steps = 30;           ///< the angles' bins over a turn
  double scene_sampling = 0.04;   ///< the segment's points thinned to this spacing ...
  double scene_reference = 0.2;   ///< ... and this share of them reference points
  double normal_radius = 0.006;   ///< [m] a point's normal: the plane fitted to its neighbours this near (or 1.5 spacings, if more)
  double edge_clearance = 0.006;  ///< [m] the model's points this near a sharp edge left out (the camera's normals bend round it)
  int bucket_cap = 64;            ///< a pair's bin of n entries keeps every floor(n / bucket_cap)-th: cap to 2 cap - 1 entries (0: all)
  int hypotheses = 12;            ///< the best-voted poses of each model refined and verified
  // Hypotheses from faces: each model's plane faces laid on the segment's largest plane (a face's point pairs locate nothing).
  bool plane_faces = true;
  double plane_spacing = 0.003;   ///< [m] the segment's points thinned to this spacing to find its largest plane ...
  double plane_tolerance = 0.003; ///< [m] ... the points this near it (their normals within 15 degrees of its) ...
  double plane_share = 0.3;       ///< ... at least this share of them
  double plane_min_area = 1e-4;   ///< [m^2] a model's faces this large (their triangles grouped by plane)
  double plane_fit = 0.005;       ///< [m] a face fits when its smallest rectangle's half sides are within this of the segment's
  // Refinement.
  int icp_iterations = 12;
  double icp_reject = 0.01;       ///< [m] pairs further apart than this are left out
  // Verification: drawn and seen depth agree within agree + depth_sigma_k z^2 * 3.
  double agree = 0.004;           ///< [m]
  double depth_sigma_k = 0.0015;  ///< the sensor's depth noise: sigma = k z^2 [1/m]
  bool turns = true;              ///< the best pose turned half a turn about each of its model's box axes, refined and verified too
  double min_score = 0.6;         ///< the best pose's score must reach this, else no pose ...
  // ... unless the segment holds more than one object (touching objects the segmentation merged):
  // a pose explaining a part of it is taken when, leaving the segment's pixels it does not cover
  // aside, this share of the pixels that tell agree with it ...
  double min_fit = 0.85;
  double min_seen = 0.4;          ///< ... and at least this share of its drawing is seen (agrees)
  // A view (estimateView): what a pose does not explain of its segment is posed again when a
  // connected part of it covers this much of the bin, seen from the camera (as many pixels as a
  // patch this large facing the camera at their depth).
  double rest_area = 4e-4;        ///< [m^2]
  double explain_band = 0.015;    ///< [m] a pixel is the pose's when the model drawn there, or a pixel
  int explain_margin = 2;         ///< [px at 640 wide] this near, is within this depth of it
};

struct ModelPose {
  bool ok = false;
  int model = -1;                         ///< index into the estimator's models
  Pose T_world_object = Pose::Identity();
  /// Verification: agreeing / (agreeing + contradicting) pixels, where the segment's pixels the
  /// model leaves uncovered contradict it too.
  double score = 0;
  int agree = 0, contradict = 0;
  int uncovered = 0;                      ///< of contradict: the segment's pixels where the model is not drawn
  int drawn = 0;                          ///< pixels where the model is drawn and the camera has depth
  bool partial = false;                   ///< it explains a part of the segment only (min_fit)
  int hypotheses = 0;                     ///< poses verified (every model's)
  double seconds = 0;                     ///< wall clock (benchmarks print it; nothing decides by it)
  std::string reason;                     ///< why no pose (when !ok)
};

/// A view's known objects: each pose and the pixels it explains; what no model explains.
struct ViewPoses {
  std::vector<ModelPose> poses;
  std::vector<Segment> explained;  ///< each pose's pixels (its segment's and those it took from others)
  std::vector<Segment> unknown;    ///< segments, or parts of them, no model explains: unknown objects
  std::vector<Segment> small;      ///< parts left too small to be objects but rising above the floor (obstacles)
  int estimates = 0;               ///< segments and parts the models were tried on
  double seconds = 0;              ///< wall clock (measured; decides nothing)
};

/// The models' point-pair tables are built once; estimate() is const (and safe from many threads).
class ModelPoseEstimator {
 public:
  explicit ModelPoseEstimator(std::vector<std::shared_ptr<const ObjectModel>> models, const ModelPoseOptions& o = {});
  ~ModelPoseEstimator();
  ModelPoseEstimator(const ModelPoseEstimator&) = delete;
  ModelPoseEstimator& operator=(const ModelPoseEstimator&) = delete;

  const std::vector<std::shared_ptr<const ObjectModel>>& models() const;
  /// The pose of the object seen as `segment` (its pixels and points) in `frame` (its depth and camera).
  ModelPose estimate(const Frame& frame, const Segment& segment) const;
  /// Every segment of a view posed, the largest first. A pose's pixels (where the model drawn at it
  /// meets the seen depth, its segment's and any other's) are its own: later segments lose them,
  /// and what it leaves of its segment, in connected parts as large as rest_area, is posed again
  /// (objects the segmentation merged); smaller parts are obstacles or nothing, by `so`'s rules.
  ViewPoses estimateView(const Frame& frame, const std::vector<Segment>& segments, const SegmentationOptions& so) const;
  /// Verification of one pose of model `model` (as estimate() scores its hypotheses).
  ModelPose verify(const Frame& frame, const Segment& segment, int model, const Pose& T_world_object) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mm
