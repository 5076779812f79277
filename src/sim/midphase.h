// A mid-phase for MuJoCo 2.2's collision pipeline, which has none: its broad phase passes every
// geom pair whose bounding spheres overlap to the narrow-phase function, and a large box (the
// table under the robot, a bin wall) overlaps nearly everything, so each step ran some 40
// narrow-phase tests (capsule-box, box-box, and every geom against the floor plane) that found
// nothing. Wrapped narrow-phase functions for pairs with a box or a plane first bound the pair's
// distance from below (the other geom's bounding sphere against the box or above the plane; the
// separating axes of two boxes) and return no contact when that bound exceeds the pair's margin:
// exactly the contacts MuJoCo would find, fewer tests.
// MuJoCo 3 added the same idea as its "midphase" (a BVH per body).
#pragma once

struct mjModel_;
struct mjData_;

namespace mm {

/// Wraps MuJoCo's narrow-phase table (mjCOLLISIONFUNC) once per process.
void installMidphase();
/// On this thread, whether the wrapped tests skip pairs (true) or only forward (false: MuJoCo as
/// it is, the bench's baseline). Set by SimWorld before it steps its model.
void setMidphase(bool on);
/// [m] A lower bound on the distance between geoms g1 and g2 at the poses in d (negative when they
/// may overlap): their bounding spheres' gap, a box's distance to the other's bounding sphere, and
/// two boxes' largest gap along their separating axes, whichever is largest.
double geomGapLowerBound(const mjModel_* m, const mjData_* d, int g1, int g2);

}  // namespace mm
