#include "sim/midphase.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <mutex>

namespace mm {

namespace {

mjfCollision g_narrow[mjNGEOMTYPES][mjNGEOMTYPES] = {};
mjfCollision g_plane_mesh = nullptr;  // MuJoCo's own plane-mesh collider
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

// A free body's mesh (an object from a mesh file) on a plane: up to four contacts spread over the
// hull's vertices within the margin — the deepest, the one farthest from it, the farthest from
// that line on each side. MuJoCo 2.2's plane-convex collider gives at most three, the support
// vertex and two of its hull neighbours: on a flat face of more than three vertices (a hexagon, a
// rectangle) they span only part of it, the centre of mass can fall outside, and the solid rocks
// on its face (measured: a hexagonal prism resting 0.72 mm deep, chattering at 7 mm/s).
int planeMesh(const mjModel* m, const mjData* d, mjContact* con, int g1, int g2, mjtNum margin) {
  const int mesh = m->geom_dataid[g2];
  const mjtNum* R1 = d->geom_xmat + 9 * g1;
  const mjtNum n[3] = {R1[2], R1[5], R1[8]};
  const mjtNum* p1 = d->geom_xpos + 3 * g1;
  const mjtNum* p2 = d->geom_xpos + 3 * g2;
  const mjtNum* R2 = d->geom_xmat + 9 * g2;
  const float* vert = m->mesh_vert + 3 * m->mesh_vertadr[mesh];
  struct Point {
    mjtNum p[3], dist;
  };
  Point pts[4];
  int count = 0;
  auto world = [&](int i, Point& q) {
    const mjtNum v[3] = {vert[3 * i], vert[3 * i + 1], vert[3 * i + 2]};
    for (int k = 0; k < 3; ++k) q.p[k] = p2[k] + R2[3 * k] * v[0] + R2[3 * k + 1] * v[1] + R2[3 * k + 2] * v[2];
    q.dist = n[0] * (q.p[0] - p1[0]) + n[1] * (q.p[1] - p1[1]) + n[2] * (q.p[2] - p1[2]);
  };
  // Each pick maximises a score over the vertices within the margin (strictly better only: ties go
  // to the lower index, so the contacts do not depend on anything but the state).
  auto pick = [&](const std::function<mjtNum(const Point&)>& score) {
    Point best{}, q{};
    mjtNum best_score = 0;
    bool found = false;
    for (int i = 0; i < m->mesh_vertnum[mesh]; ++i) {
      world(i, q);
      if (q.dist > margin) continue;
      const mjtNum s = score(q);
      if (!found || s > best_score) best = q, best_score = s, found = true;
    }
    if (found) pts[count++] = best;
    return found ? best_score : mjtNum(-1);
  };
  auto d3 = [](const mjtNum* a, const mjtNum* b) {
    return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
  };
  pick([](const Point& q) { return -q.dist; });
  if (count == 0) return 0;
  const mjtNum eps = 1e-3 * m->geom_rbound[g2];
  if (pick([&](const Point& q) { return d3(q.p, pts[0].p); }) < eps) {
    count = 1;
  } else {
    // Signed distance from the line a-b, in the plane: (b - a) x (q - a) . n.
    const Point a = pts[0], b = pts[1];
    auto side = [&](const Point& q) {
      const mjtNum u[3] = {b.p[0] - a.p[0], b.p[1] - a.p[1], b.p[2] - a.p[2]}, w[3] = {q.p[0] - a.p[0], q.p[1] - a.p[1], q.p[2] - a.p[2]};
      return n[0] * (u[1] * w[2] - u[2] * w[1]) + n[1] * (u[2] * w[0] - u[0] * w[2]) + n[2] * (u[0] * w[1] - u[1] * w[0]);
    };
    if (pick(side) < eps * d3(a.p, b.p)) --count;
    if (pick([&](const Point& q) { return -side(q); }) < eps * d3(a.p, b.p)) --count;
  }
  for (int c = 0; c < count; ++c) {
    con[c].dist = pts[c].dist;
    for (int k = 0; k < 3; ++k) con[c].pos[k] = pts[c].p[k] - 0.5 * pts[c].dist * n[k], con[c].frame[k] = n[k];
    for (int k = 3; k < 9; ++k) con[c].frame[k] = 0;
  }
  return count;
}

// MuJoCo 2.2's plane-convex collider, or ours for an object's mesh (a mesh on a free body).
int planeConvex(const mjModel* m, const mjData* d, mjContact* con, int g1, int g2, mjtNum margin) {
  const int b = m->geom_bodyid[g2];
  if (m->geom_type[g2] == mjGEOM_MESH && m->geom_dataid[g2] >= 0 && m->body_jntnum[b] == 1 && m->jnt_type[m->body_jntadr[b]] == mjJNT_FREE)
    return planeMesh(m, d, con, g1, g2, margin);
  return g_plane_mesh(m, d, con, g1, g2, margin);
}

}  // namespace

void installMidphase() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (int i = 0; i < mjNGEOMTYPES; ++i)
      for (int j = 0; j < mjNGEOMTYPES; ++j) {
        g_narrow[i][j] = mjCOLLISIONFUNC[i][j];
        if (i == mjGEOM_PLANE && j == mjGEOM_MESH && g_narrow[i][j]) g_plane_mesh = g_narrow[i][j], g_narrow[i][j] = planeConvex;
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
