#include "sim/midphase.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <mutex>

namespace mm {

namespace {

mjfCollision g_narrow[mjNGEOMTYPES][mjNGEOMTYPES] = {};
thread_local bool t_on = false;

// Distance from point p to the box g (its centre, rotation and half-sizes), 0 inside.
mjtNum pointToBox(const mjModel* m, const mjData* d, int g, const mjtNum* p) {
  const mjtNum* c = d->geom_xpos + 3 * g;
  const mjtNum* R = d->geom_xmat + 9 * g;  // row-major: columns are the box's axes
  const mjtNum* h = m->geom_size + 3 * g;
  mjtNum sq = 0;
  for (int i = 0; i < 3; ++i) {
    const mjtNum local = (p[0] - c[0]) * R[i] + (p[1] - c[1]) * R[3 + i] + (p[2] - c[2]) * R[6 + i];
    const mjtNum out = std::abs(local) - h[i];
    if (out > 0) sq += out * out;
  }
  return std::sqrt(sq);
}

// A lower bound on the distance between two boxes: the largest gap along the 15 separating axes
// (each box's 3 face normals and the 9 cross products of their edges).
mjtNum boxBoxGap(const mjModel* m, const mjData* d, int a, int b) {
  const mjtNum* ca = d->geom_xpos + 3 * a;
  const mjtNum* cb = d->geom_xpos + 3 * b;
  const mjtNum* Ra = d->geom_xmat + 9 * a;
  const mjtNum* Rb = d->geom_xmat + 9 * b;
  const mjtNum* ha = m->geom_size + 3 * a;
  const mjtNum* hb = m->geom_size + 3 * b;
  mjtNum A[3][3], B[3][3];  // A[i]: box a's axis i in the world
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) A[i][k] = Ra[3 * k + i], B[i][k] = Rb[3 * k + i];
  const mjtNum t[3] = {cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2]};
  mjtNum best = -1e300;
  auto axis = [&](const mjtNum L[3]) {
    const mjtNum n = std::sqrt(L[0] * L[0] + L[1] * L[1] + L[2] * L[2]);
    if (n < 1e-9) return;
    mjtNum ra = 0, rb = 0;
    for (int i = 0; i < 3; ++i) {
      ra += ha[i] * std::abs(A[i][0] * L[0] + A[i][1] * L[1] + A[i][2] * L[2]);
      rb += hb[i] * std::abs(B[i][0] * L[0] + B[i][1] * L[1] + B[i][2] * L[2]);
    }
    best = std::max(best, (std::abs(t[0] * L[0] + t[1] * L[1] + t[2] * L[2]) - ra - rb) / n);
  };
  for (int i = 0; i < 3; ++i) axis(A[i]), axis(B[i]);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const mjtNum L[3] = {A[i][1] * B[j][2] - A[i][2] * B[j][1], A[i][2] * B[j][0] - A[i][0] * B[j][2],
                           A[i][0] * B[j][1] - A[i][1] * B[j][0]};
      axis(L);
    }
  return best;
}

int midphase(const mjModel* m, const mjData* d, mjContact* con, int g1, int g2, mjtNum margin) {
  const int t1 = m->geom_type[g1], t2 = m->geom_type[g2];
  if (t_on && t1 == mjGEOM_PLANE && t2 != mjGEOM_HFIELD) {
    // The other's bounding sphere above the plane's surface (a plane collides as a half-space).
    const mjtNum* R = d->geom_xmat + 9 * g1;  // its normal: the local z axis
    const mjtNum* c = d->geom_xpos + 3 * g1;
    const mjtNum* p = d->geom_xpos + 3 * g2;
    const mjtNum height = (p[0] - c[0]) * R[2] + (p[1] - c[1]) * R[5] + (p[2] - c[2]) * R[8];
    if (height - m->geom_rbound[g2] > margin) return 0;
  } else if (t_on && t1 != mjGEOM_PLANE && t2 != mjGEOM_PLANE && t1 != mjGEOM_HFIELD && t2 != mjGEOM_HFIELD) {
    // A box against the other's bounding sphere (its radius about the geom's frame origin).
    const int box = t1 == mjGEOM_BOX ? g1 : g2, other = box == g1 ? g2 : g1;
    if (pointToBox(m, d, box, d->geom_xpos + 3 * other) - m->geom_rbound[other] > margin) return 0;
    if (t1 == mjGEOM_BOX && t2 == mjGEOM_BOX && boxBoxGap(m, d, g1, g2) > margin) return 0;
  }
  return g_narrow[t1][t2](m, d, con, g1, g2, margin);
}

}  // namespace

void installMidphase() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (int i = 0; i < mjNGEOMTYPES; ++i)
      for (int j = 0; j < mjNGEOMTYPES; ++j) {
        g_narrow[i][j] = mjCOLLISIONFUNC[i][j];
        if (g_narrow[i][j] && (i == mjGEOM_BOX || j == mjGEOM_BOX || i == mjGEOM_PLANE)) mjCOLLISIONFUNC[i][j] = midphase;
      }
  });
}

void setMidphase(bool on) { t_on = on; }

double geomGapLowerBound(const mjModel* m, const mjData* d, int g1, int g2) {
  const mjtNum* p1 = d->geom_xpos + 3 * g1;
  const mjtNum* p2 = d->geom_xpos + 3 * g2;
  const mjtNum dx = p1[0] - p2[0], dy = p1[1] - p2[1], dz = p1[2] - p2[2];
  mjtNum gap = std::sqrt(dx * dx + dy * dy + dz * dz) - m->geom_rbound[g1] - m->geom_rbound[g2];
  const bool box1 = m->geom_type[g1] == mjGEOM_BOX, box2 = m->geom_type[g2] == mjGEOM_BOX;
  if (box1) gap = std::max(gap, pointToBox(m, d, g1, p2) - m->geom_rbound[g2]);
  if (box2) gap = std::max(gap, pointToBox(m, d, g2, p1) - m->geom_rbound[g1]);
  if (box1 && box2) gap = std::max(gap, boxBoxGap(m, d, g1, g2));
  return gap;
}

}  // namespace mm
