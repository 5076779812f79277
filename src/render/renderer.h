// Camera images of a SimWorld: RGB, depth in metres and per-object segmentation, from the scene's
// cameras, offscreen through EGL (render/gl_context.h).
//
// Conventions (core/camera.h states them for every image):
// - Images are row-major with the top row first (as OpenCV's cv::Mat), pixel (u, v) = (column, row).
// - Camera frames are OpenCV's: x right, y down, z along the optical axis. A MuJoCo camera looks
//   along its own -z with y up, so T_world_camera = T_world_mujococam * diag(1, -1, -1).
// - The pinhole model has square pixels (MuJoCo's fovy is vertical; fx = fy = (height/2) / tan(fovy/2))
//   and the principal point at the image centre, cx = (width-1)/2, cy = (height-1)/2, in the
//   convention where pixel (0,0)'s centre is at (0,0).
// - Depth is the z coordinate in that frame [m] (not the ray length), linearized from MuJoCo's
//   depth buffer; 0 where nothing is hit (the far plane).
// - Segmentation holds a SegmentLabel per pixel (sim/sim_world.h): 0 scene, 1 robot, 2 + k object k,
//   255 an obstacle. Rendered without multisampling so labels, depth and colour agree at edges.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/geometry.h"

namespace mm {

class SimWorld;
class GlContext;

class Renderer {
 public:
  /// An offscreen context on this thread (`egl`: auto, device, surfaceless); null with `why` said
  /// when none can be made.
  static std::unique_ptr<Renderer> create(const std::string& egl, std::string* why);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// The OpenGL renderer, its version and the EGL platform (pixels differ between renderers).
  const std::string& description() const;
  /// The scene camera `name` at width x height [px]; throws InputError naming `file` and the key
  /// that named the camera when the scene has no such camera.
  CameraModel camera(const SimWorld& world, const std::string& name, int width, int height, const std::string& file,
                     const std::string& key = "render.camera") const;
  /// Renders the world as it is now through `camera` (its pose is re-read: a wrist camera moves).
  /// `kinds`: a mask of ImageKind. `only_label` >= 0: only the geoms of that segmentation label are
  /// drawn (an object alone: its whole silhouette, however hidden it is in the scene).
  Frame render(const SimWorld& world, const CameraModel& camera, unsigned kinds, int only_label = -1);

 private:
  Renderer();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mm
