// Views of a SimWorld written as a dataset in the BOP format (bop_toolkit's
// docs/bop_datasets_format.md), what pose-estimation research trains and tests on:
//
//   <root>/camera.json                      the camera (the last view's intrinsics, depth_scale)
//   <root>/models/obj_<id>.ply               each object's surface [mm] (as the renderer draws it)
//   <root>/models/models_info.json           per obj_id: diameter, min_x/y/z, size_x/y/z [mm], symmetries
//   <root>/<split>/<scene>/scene_camera.json per image: cam_K, depth_scale, cam_R_w2c, cam_t_w2c [mm]
//   <root>/<split>/<scene>/scene_gt.json     per image: [{obj_id, cam_R_m2c, cam_t_m2c [mm]}]
//   <root>/<split>/<scene>/scene_gt_info.json per image: [{bbox_obj, bbox_visib, px_count_all,
//                                            px_count_valid, px_count_visib, visib_fract}]
//   <root>/<split>/<scene>/rgb/<im>.png, depth/<im>.png (16-bit, value x depth_scale = mm),
//   mask/<im>_<gt>.png (the object's whole silhouette), mask_visib/<im>_<gt>.png (what is seen of it)
//
// Ids: a scene and its images by number (6 digits); an object model by its surface: the same
// geometry, the same obj_id (from 1). An object is listed in an image when some of its silhouette is
// in it (rendered alone, opaque), however hidden (visib_fract 0 when nothing of it is seen). Poses
// are the simulator's as drawn, the camera's where it drew from (a knocked camera's true pose, not
// its mount's). The depth is the sensor's as the view came (before a fault's blackout or dropout,
// and before the robot's own points are taken out).
#pragma once
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "render/renderer.h"
#include "robot/solid_mesh.h"

namespace mm {

class BopWriter {
 public:
  /// `root` is created if need be; `split`: the images' folder under it (e.g. "train").
  BopWriter(std::filesystem::path root, std::string split);
  ~BopWriter();
  BopWriter(const BopWriter&) = delete;
  BopWriter& operator=(const BopWriter&) = delete;

  /// Scene `scene` begins (its images count from 0); the one before is written.
  void beginScene(uint64_t scene);
  /// Adds the view `seen` of `world` as it is now: its depth as the sensor gave it; its colour and
  /// labels rendered again; each object near the view rendered alone for its whole silhouette.
  void addView(Renderer& renderer, const SimWorld& world, const Frame& seen);
  /// A mesh object's symmetries, as its catalogue kind declares them (`group`: identity first), by
  /// its collision pieces (the world's objects of that kind share them): written in models_info.
  void declareSymmetries(std::shared_ptr<const std::vector<ConvexPiece>> pieces, std::vector<Mat3> group);
  /// Writes the open scene's files, the models seen so far, models_info.json and camera.json
  /// (each JSON file by a temporary file and a rename). Throws OutputError when it cannot.
  void finish();
  int views() const { return views_; }
  int scenes() const { return scenes_; }  ///< written so far (a scene with no image is not)
  int models() const;

 private:
  struct Model;
  struct Scene;
  int modelId(const SimWorld& world, int object);
  void writeScene();
  std::filesystem::path root_;
  std::string split_;
  std::unique_ptr<Scene> scene_;
  std::vector<Model> models_;
  std::map<std::pair<uint64_t, int>, int> model_of_;  ///< (the world's model serial, object) -> obj_id
  std::map<std::shared_ptr<const std::vector<ConvexPiece>>, std::vector<Mat3>> declared_;  ///< declareSymmetries
  CameraModel camera_;  ///< the last view's (camera.json)
  int views_ = 0, scenes_ = 0;
};

}  // namespace mm
