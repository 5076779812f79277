#include "core/obb.h"

#include <cmath>

namespace mm {

bool boxesOverlap(const OrientedBox& a, const OrientedBox& b) {
  const Mat3 R = a.axes.transpose() * b.axes;               // b's axes in a's frame
  const Vec3 t = a.axes.transpose() * (b.centre - a.centre);  // b's centre in a's frame
  // |R| with an epsilon: two parallel edges give a null cross product, which must not separate.
  const Mat3 A = (R.cwiseAbs().array() + 1e-9).matrix();
  const Vec3& ha = a.half;
  const Vec3& hb = b.half;
  for (int i = 0; i < 3; ++i)  // a's face normals
    if (std::abs(t(i)) > ha(i) + hb.dot(A.row(i).transpose())) return false;
  for (int j = 0; j < 3; ++j)  // b's face normals
    if (std::abs(t.dot(R.col(j))) > ha.dot(A.col(j)) + hb(j)) return false;
  for (int i = 0; i < 3; ++i)  // a's edge i crossed with b's edge j
    for (int j = 0; j < 3; ++j) {
      const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      const double ra = ha(i1) * A(i2, j) + ha(i2) * A(i1, j);
      const double rb = hb(j1) * A(i, j2) + hb(j2) * A(i, j1);
      if (std::abs(t(i2) * R(i1, j) - t(i1) * R(i2, j)) > ra + rb) return false;
    }
  return true;
}

}  // namespace mm
