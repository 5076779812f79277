#include "kinematics/panda_analytic.h"

#include <cmath>

#include "core/error.h"

namespace mm {
namespace {

Mat3 Rx(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Mat3 R;
  R << 1, 0, 0, 0, c, -s, 0, s, c;
  return R;
}
Mat3 Rz(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Mat3 R;
  R << c, -s, 0, s, c, 0, 0, 0, 1;
  return R;
}

// Modified DH link transform T_{i-1,i} = Tx(a) Rx(alpha) Tz(d) Rz(q): rotation and translation.
struct Link {
  Mat3 R;
  Vec3 p;
};
Link dh(double a, double alpha, double d, double q) {
  const Mat3 Ra = Rx(alpha);
  return {Ra * Rz(q), Vec3(a, 0, 0) + Ra.col(2) * d};
}
// (R1, p1) * (R2, p2)^-1
void timesInverse(Mat3& R1, Vec3& p1, const Link& l) {
  R1 = R1 * l.R.transpose();
  p1 = p1 - R1 * l.p;
}

bool near(double a, double b) { return std::abs(a - b) < 1e-9; }

}  // namespace

PandaAnalyticIk::PandaAnalyticIk(const RobotModel& robot) {
  const auto& j = robot.spec().joints;
  const double h = M_PI / 2;
  const bool shape = j.size() == 7 && near(j[0].a, 0) && near(j[0].alpha, 0) && near(j[1].a, 0) && near(j[1].d, 0) &&
                     near(j[1].alpha, -h) && near(j[2].a, 0) && near(j[2].alpha, h) && near(j[3].d, 0) &&
                     near(j[3].alpha, h) && near(j[4].alpha, -h) && near(j[5].a, 0) && near(j[5].d, 0) &&
                     near(j[5].alpha, h) && near(j[6].d, 0) && near(j[6].alpha, h);
  bool dh = true;
  for (int k = 0; k < robot.dof(); ++k) dh = dh && j[k].dh && robot.jointAxis(k).isApprox(Vec3::UnitZ(), 1e-12);
  if (!shape || !dh)
    throw InputError(robot.spec().file, "the analytic IK needs a Panda-shaped modified DH chain (7 joints, the Panda's alphas and zero offsets)");
  d1_ = j[0].d, d3_ = j[2].d, a4_ = j[3].a, a5_ = j[4].a, d5_ = j[4].d, a7_ = j[6].a, alpha7_ = j[6].alpha;
  T_tcp_inv_ = robot.T_flange_tcp().inverse();
  q6_lower_ = robot.lower()[5];
}

int PandaAnalyticIk::solve(const Pose& T_0_tcp, double q7, double q1_singular, std::array<Joints, 16>& out) const {
  int count = 0;
  const double h = M_PI / 2;
  // Frame 6 from the flange and q7.
  const Pose T_0_7 = T_0_tcp * T_tcp_inv_;
  Mat3 R_0_6 = T_0_7.linear();
  Vec3 W = T_0_7.translation();
  timesInverse(R_0_6, W, dh(a7_, alpha7_, 0.0, q7));
  const Vec3 S(0, 0, d1_);
  // The shoulder in frame 6: p = (X c5 c6 + Z s6, -X c5 s6 + Z c6, X s5) with
  // X = -a4 c4 - d3 s4 - a5 and Z = a4 s4 - d3 c4 - d5; |p|^2 = X^2 + Z^2 fixes q4.
  const Vec3 p = R_0_6.transpose() * (S - W);
  const double A = a5_ * a4_ + d5_ * d3_, B = a5_ * d3_ - d5_ * a4_;
  const double L = a4_ * a4_ + d3_ * d3_ + a5_ * a5_ + d5_ * d5_;
  const double C = 0.5 * (p.squaredNorm() - L), Rn = std::hypot(A, B);
  if (std::abs(C) > Rn) return 0;  // out of reach for this q7
  const double phi = std::atan2(B, A), delta = std::acos(std::clamp(C / Rn, -1.0, 1.0));
  for (double q4 : {phi + delta, phi - delta}) {
    q4 = wrapAngle(q4);
    const double c4 = std::cos(q4), s4 = std::sin(q4);
    const double X = -a4_ * c4 - d3_ * s4 - a5_, Z = a4_ * s4 - d3_ * c4 - d5_;
    if (std::abs(X) < 1e-12) continue;
    const double s5 = p.z() / X;
    if (std::abs(s5) > 1.0) continue;
    for (double sign5 : {1.0, -1.0}) {
      const double c5 = sign5 * std::sqrt(std::max(0.0, 1.0 - s5 * s5));
      const double q5 = std::atan2(s5, c5);
      const double q6 = wrapAngle(std::atan2(Z, X * c5) - std::atan2(p.y(), p.x()));
      // Frame 3's orientation: R_0_3 = R_0_6 R_56^T R_45^T R_34^T.
      const Mat3 R_0_3 = R_0_6 * (Rx(h) * Rz(q4) * Rx(-h) * Rz(q5) * Rx(h) * Rz(q6)).transpose();
      // z3 = (c1 s2, s1 s2, c2): the upper arm's direction.
      const Vec3 z3 = R_0_3.col(2);
      const double s2_abs = std::hypot(z3.x(), z3.y());
      const int branches = s2_abs < 1e-9 ? 1 : 2;
      for (int b = 0; b < branches; ++b) {
        double q1, q2;
        if (branches == 1) {
          q1 = q1_singular;
          q2 = std::atan2(0.0, z3.z());
        } else if (b == 0) {
          q1 = std::atan2(z3.y(), z3.x());
          q2 = std::atan2(s2_abs, z3.z());
        } else {
          q1 = std::atan2(-z3.y(), -z3.x());
          q2 = std::atan2(-s2_abs, z3.z());
        }
        // Rz(q3) = (Rz(q1) Rx(-pi/2) Rz(q2) Rx(pi/2))^T R_0_3.
        const Mat3 M = (Rz(q1) * Rx(-h) * Rz(q2) * Rx(h)).transpose() * R_0_3;
        const double q3 = std::atan2(M(1, 0), M(0, 0));
        Joints& q = out[count++];
        q << q1, q2, q3, q4, q5, q6, wrapAngle(q7);
        if (q6 < q6_lower_) {  // the same posture with joint 6 turned a full circle
          out[count] = q;
          out[count++][5] = q6 + 2 * M_PI;
        }
      }
    }
  }
  return count;
}

}  // namespace mm
