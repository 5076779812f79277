#include "sim/midphase.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <mutex>
#include <vector>

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

int convexPair(const mjModel* m, const mjData* d, mjContact* con, int g1, int g2, mjtNum margin, mjfCollision ccd);
bool objectMesh(const mjModel* m, int g);

int midphase(const mjModel* m, const mjData* d, mjContact* con, int g1, int g2, mjtNum margin) {
  const int t1 = m->geom_type[g1], t2 = m->geom_type[g2];
  if (t_on && t1 == mjGEOM_PLANE && t2 != mjGEOM_HFIELD) {
    // The other's bounding sphere above the plane's surface (a plane collides as a half-space).
    const mjtNum* R = d->geom_xmat + 9 * g1;  // its normal: the local z axis
    const mjtNum* c = d->geom_xpos + 3 * g1;
    const mjtNum* p = d->geom_xpos + 3 * g2;
    const mjtNum height = (p[0] - c[0]) * R[2] + (p[1] - c[1]) * R[5] + (p[2] - c[2]) * R[8];
    if (height - m->geom_rbound[g2] > margin) return 0;
  } else if (t_on && (t1 == mjGEOM_BOX || t2 == mjGEOM_BOX) && t1 != mjGEOM_PLANE && t2 != mjGEOM_PLANE && t1 != mjGEOM_HFIELD &&
             t2 != mjGEOM_HFIELD) {
    // A box against the other's bounding sphere (its radius about the geom's frame origin).
    const int box = t1 == mjGEOM_BOX ? g1 : g2, other = box == g1 ? g2 : g1;
    if (pointToBox(m, d, box, d->geom_xpos + 3 * other) - m->geom_rbound[other] > margin) return 0;
    if (t1 == mjGEOM_BOX && t2 == mjGEOM_BOX && boxBoxGap(m, d, g1, g2) > margin) return 0;
  }
  if ((t1 == mjGEOM_BOX || t1 == mjGEOM_MESH) && t2 == mjGEOM_MESH && (objectMesh(m, g1) || objectMesh(m, g2)))
    return convexPair(m, d, con, g1, g2, margin, g_narrow[t1][t2]);
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

// A convex geom as MuJoCo collides it, in the world: its vertices and its faces' planes (unit
// outward normal n, offset o: inside where n.x <= o). A box's corners and faces; a mesh's hull
// (MuJoCo's graph of it: vertices and triangles).
struct Polytope {
  std::vector<std::array<mjtNum, 3>> v;
  std::vector<std::array<mjtNum, 4>> f;
};

bool polytope(const mjModel* m, const mjData* d, int g, Polytope& P) {
  const mjtNum* c = d->geom_xpos + 3 * g;
  const mjtNum* R = d->geom_xmat + 9 * g;
  auto world = [&](const mjtNum* l) {
    return std::array<mjtNum, 3>{c[0] + R[0] * l[0] + R[1] * l[1] + R[2] * l[2], c[1] + R[3] * l[0] + R[4] * l[1] + R[5] * l[2],
                                 c[2] + R[6] * l[0] + R[7] * l[1] + R[8] * l[2]};
  };
  P.v.clear();
  P.f.clear();
  if (m->geom_type[g] == mjGEOM_BOX) {
    const mjtNum* h = m->geom_size + 3 * g;
    for (int k = 0; k < 8; ++k) {
      const mjtNum l[3] = {(k & 1) ? h[0] : -h[0], (k & 2) ? h[1] : -h[1], (k & 4) ? h[2] : -h[2]};
      P.v.push_back(world(l));
    }
    for (int a = 0; a < 3; ++a)
      for (mjtNum s : {-1.0, 1.0}) {
        const std::array<mjtNum, 3> n{s * R[a], s * R[3 + a], s * R[6 + a]};
        P.f.push_back({n[0], n[1], n[2], n[0] * c[0] + n[1] * c[1] + n[2] * c[2] + h[a]});
      }
    return true;
  }
  const int mesh = m->geom_dataid[g];
  if (m->geom_type[g] != mjGEOM_MESH || mesh < 0 || m->mesh_graphadr[mesh] < 0) return false;
  const int* graph = m->mesh_graph + m->mesh_graphadr[mesh];
  const int numvert = graph[0], numface = graph[1];
  const int* globalid = graph + 2 + numvert;
  const int* face = graph + 2 + 3 * numvert + 3 * numface;
  const float* vert = m->mesh_vert + 3 * m->mesh_vertadr[mesh];
  std::array<mjtNum, 3> mean{0, 0, 0};
  for (int i = 0; i < numvert; ++i) {
    const mjtNum l[3] = {vert[3 * globalid[i]], vert[3 * globalid[i] + 1], vert[3 * globalid[i] + 2]};
    P.v.push_back(world(l));
    for (int k = 0; k < 3; ++k) mean[k] += P.v.back()[k] / numvert;
  }
  for (int t = 0; t < numface; ++t) {
    std::array<mjtNum, 3> q[3];
    for (int j = 0; j < 3; ++j) {
      const float* l = vert + 3 * face[3 * t + j];
      const mjtNum lv[3] = {l[0], l[1], l[2]};
      q[j] = world(lv);
    }
    const mjtNum u[3] = {q[1][0] - q[0][0], q[1][1] - q[0][1], q[1][2] - q[0][2]}, w[3] = {q[2][0] - q[0][0], q[2][1] - q[0][1], q[2][2] - q[0][2]};
    mjtNum n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    const mjtNum len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (len < 1e-12) continue;
    for (mjtNum& x : n) x /= len;
    mjtNum o = n[0] * q[0][0] + n[1] * q[0][1] + n[2] * q[0][2];
    if (n[0] * mean[0] + n[1] * mean[1] + n[2] * mean[2] > o) {  // wound inward: the centre is outside it
      for (mjtNum& x : n) x = -x;
      o = -o;
    }
    P.f.push_back({n[0], n[1], n[2], o});
  }
  return !P.f.empty();
}

// An object's mesh against a box or another mesh: MuJoCo 2.2's general convex collider (libccd)
// gives one contact, so a solid resting on another rocks and sinks in by millimetres. Here the
// contact is that one's normal and depth over a manifold: each geom's vertices within kFaceTol of
// its extreme along the normal (the face, edge or vertex each turns to the other), projected on
// the contact plane, their convex outlines intersected (Sutherland-Hodgman), and up to four of
// the intersection's corners spread as on a plane. A point or nothing in common: libccd's one.
constexpr mjtNum kFaceTol = 1e-3;  // [m] a face tilted by up to about a degree over 5 cm still counts as one

using P2 = std::array<mjtNum, 2>;

mjtNum cross2(const P2& o, const P2& a, const P2& b) { return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]); }

// Convex outline (counter-clockwise, monotone chain) of points in the plane.
std::vector<P2> outline(std::vector<P2> p) {
  std::sort(p.begin(), p.end());
  p.erase(std::unique(p.begin(), p.end()), p.end());
  if (p.size() < 3) return p;
  std::vector<P2> h(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross2(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross2(h[k - 2], h[k - 1], p[i - 1]) <= 0) --k;
    h[k++] = p[i - 1];
  }
  h.resize(k - 1);
  return h;
}

// The part of `subject` (a convex outline, a segment or a point) inside the convex outline `clip`
// (counter-clockwise, at least three corners).
std::vector<P2> clipTo(std::vector<P2> subject, const std::vector<P2>& clip) {
  for (size_t e = 0; e < clip.size() && !subject.empty(); ++e) {
    const P2 &a = clip[e], &b = clip[(e + 1) % clip.size()];
    std::vector<P2> out;
    const size_t n = subject.size();
    for (size_t i = 0; i < n; ++i) {
      const P2 &p = subject[i], &q = subject[(i + 1) % n];
      const mjtNum sp = cross2(a, b, p), sq = cross2(a, b, q);
      if (sp >= 0) out.push_back(p);
      if (n > 1 && (i + 1 < n || n > 2) && ((sp >= 0) != (sq >= 0))) {
        const mjtNum t = sp / (sp - sq);
        out.push_back({p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])});
      }
    }
    subject = std::move(out);
  }
  return subject;
}

int convexPair(const mjModel* m, const mjData* d, mjContact* con, int g1, int g2, mjtNum margin, mjfCollision ccd) {
  const int n0 = ccd(m, d, con, g1, g2, margin);
  if (n0 != 1) return n0;
  thread_local Polytope A, B;
  if (!polytope(m, d, g1, A) || !polytope(m, d, g2, B)) return n0;
  // The contact plane: through libccd's point, normal n (from g1 to g2), tangents u and w.
  const mjtNum* n = con[0].frame;
  const mjtNum* c0 = con[0].pos;
  mjtNum u[3];
  if (std::abs(n[0]) < 0.6) u[0] = 0, u[1] = n[2], u[2] = -n[1];
  else u[0] = -n[2], u[1] = 0, u[2] = n[0];
  const mjtNum ul = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  for (mjtNum& x : u) x /= ul;
  const mjtNum w[3] = {n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]};
  auto along = [&](const std::array<mjtNum, 3>& v, const mjtNum* axis) {
    return (v[0] - c0[0]) * axis[0] + (v[1] - c0[1]) * axis[1] + (v[2] - c0[2]) * axis[2];
  };
  // g1's vertices nearest g2 (largest along n), g2's nearest g1 (smallest along n).
  auto support = [&](const Polytope& P, mjtNum sign) {
    mjtNum extreme = -1e300;
    for (const auto& v : P.v) extreme = std::max(extreme, sign * along(v, n));
    std::vector<P2> face;
    for (const auto& v : P.v)
      if (sign * along(v, n) >= extreme - kFaceTol) face.push_back({along(v, u), along(v, w)});
    return outline(face);
  };
  const std::vector<P2> fa = support(A, 1.0), fb = support(B, -1.0);
  std::vector<P2> common;
  if (fa.size() >= 3) common = clipTo(fb, fa);
  else if (fb.size() >= 3) common = clipTo(fa, fb);
  if (common.size() < 2) return n0;
  // Spread: the first corner, the farthest from it, the farthest from that line on each side.
  auto d2 = [](const P2& a, const P2& b) { return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1])); };
  size_t pick[4] = {0, 0, 0, 0};
  int count = 1;
  const mjtNum eps = 1e-3 * std::min(m->geom_rbound[g1], m->geom_rbound[g2]);
  auto best = [&](const std::function<mjtNum(const P2&)>& score, mjtNum least) {
    size_t at = common.size();
    mjtNum top = least;
    for (size_t i = 0; i < common.size(); ++i)
      if (const mjtNum sc = score(common[i]); sc > top) top = sc, at = i;
    if (at < common.size()) pick[count++] = at;
  };
  best([&](const P2& q) { return d2(q, common[0]); }, eps);
  if (count < 2) return n0;
  const P2 a = common[pick[0]], b = common[pick[1]];
  const mjtNum least = eps * d2(a, b);
  best([&](const P2& q) { return cross2(a, b, q); }, least);
  best([&](const P2& q) { return -cross2(a, b, q); }, least);
  // Each corner's own depth: along n through it, where g1's surface ends and g2's begins (the
  // line clipped by their faces' planes), so that a tilt meets a restoring moment.
  auto bound = [&](const Polytope& P, const mjtNum* x, bool upper) {
    mjtNum t = upper ? 1e300 : -1e300;
    for (const auto& f : P.f) {
      const mjtNum fn = f[0] * n[0] + f[1] * n[1] + f[2] * n[2];
      if (std::abs(fn) < 1e-9) continue;
      const mjtNum tf = (f[3] - (f[0] * x[0] + f[1] * x[1] + f[2] * x[2])) / fn;
      if (upper && fn > 0) t = std::min(t, tf);
      if (!upper && fn < 0) t = std::max(t, tf);
    }
    return t;
  };
  const mjtNum normal[3] = {n[0], n[1], n[2]};
  mjContact out[4];
  for (int k = 0; k < count; ++k) {
    const P2& q = common[pick[k]];
    mjtNum x[3];
    for (int j = 0; j < 3; ++j) x[j] = c0[j] + q[0] * u[j] + q[1] * w[j];
    const mjtNum top1 = bound(A, x, true), bottom2 = bound(B, x, false);
    if (!(std::abs(top1) < 1 && std::abs(bottom2) < 1)) return n0;  // off either solid: no manifold here
    out[k] = con[0];
    out[k].dist = bottom2 - top1;
    for (int j = 0; j < 3; ++j) out[k].pos[j] = x[j] + 0.5 * (top1 + bottom2) * normal[j], out[k].frame[j] = normal[j];
    for (int j = 3; j < 9; ++j) out[k].frame[j] = 0;
  }
  int kept = 0;
  for (int k = 0; k < count; ++k)
    if (out[k].dist <= margin) con[kept++] = out[k];
  return kept > 0 ? kept : n0;
}

// Whether geom g is an object's mesh (a mesh on a free body).
bool objectMesh(const mjModel* m, int g) {
  const int b = m->geom_bodyid[g];
  return m->geom_type[g] == mjGEOM_MESH && m->geom_dataid[g] >= 0 && m->body_jntnum[b] == 1 && m->jnt_type[m->body_jntadr[b]] == mjJNT_FREE;
}

}  // namespace

void installMidphase() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (int i = 0; i < mjNGEOMTYPES; ++i)
      for (int j = 0; j < mjNGEOMTYPES; ++j) {
        g_narrow[i][j] = mjCOLLISIONFUNC[i][j];
        if (i == mjGEOM_PLANE && j == mjGEOM_MESH && g_narrow[i][j]) g_plane_mesh = g_narrow[i][j], g_narrow[i][j] = planeConvex;
        if (g_narrow[i][j] && (i == mjGEOM_BOX || j == mjGEOM_BOX || i == mjGEOM_PLANE || (i == mjGEOM_MESH && j == mjGEOM_MESH)))
          mjCOLLISIONFUNC[i][j] = midphase;
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
