// Each object's pixels in a view, for scoring as BOP does: its pixels in the view (where it is
// seen) and its pixels alone in the same view (the others moved away for one render each); their
// ratio is its visible fraction.
#pragma once
#include <vector>

#include "core/camera.h"
#include "../render/test_renderer.h"
#include "sim/sim_world.h"

namespace mm::testing_render {

struct ObjectPixels {
  std::vector<int> alone, visible;  ///< by the order of `active`
  double fraction(size_t k) const { return alone[k] > 0 ? static_cast<double>(visible[k]) / alone[k] : 0; }
};

/// The pixels of each object of `active` in `frame` (rendered with its segmentation from `cam`) and
/// alone; the world is left as it was found.
inline ObjectPixels objectPixels(SimWorld& w, const CameraModel& cam, const std::vector<int>& active, const Frame& frame) {
  ObjectPixels px;
  px.alone.assign(active.size(), 0);
  px.visible.assign(active.size(), 0);
  std::vector<Pose> poses;
  for (int i : active) poses.push_back(w.object(i).T_world_object);
  for (size_t k = 0; k < active.size(); ++k) {
    for (size_t j = 0; j < active.size(); ++j)
      w.setObjectPose(active[j], j == k ? poses[j] : makePose(Vec3(5.0 + static_cast<double>(j), 5, -5), Mat3::Identity()));
    w.updateKinematics();
    const Frame alone = renderer().render(w, cam, kSegmentation);
    for (uint8_t l : alone.segmentation) px.alone[k] += l == kSegmentObject0 + active[k];
    for (uint8_t l : frame.segmentation) px.visible[k] += l == kSegmentObject0 + active[k];
  }
  for (size_t j = 0; j < active.size(); ++j) w.setObjectPose(active[j], poses[j]);
  w.updateKinematics();
  return px;
}

}  // namespace mm::testing_render
