#include "kinematics/ur_analytic.h"

#include <cmath>

#include "core/error.h"

namespace mm {
namespace {

bool near(double a, double b) { return std::abs(a - b) < 1e-9; }

double wrapPi(double a) {
  a = std::remainder(a, 2 * M_PI);
  return a <= -M_PI ? a + 2 * M_PI : a;
}

}  // namespace

// The chain in modified DH (Craig): T_{k-1,k} = Rx(alpha) Tx(a) Rz(q_k) Tz(d), with
//   1: Rz(q1) Tz(d1)          2: Rx(pi/2) Rz(q2)          3: Tx(a2) Rz(q3)
//   4: Tx(a3) Rz(q4) Tz(d4)   5: Rx(pi/2) Rz(q5) Tz(d5)   6: Rx(-pi/2) Rz(q6) Tz(d6)
// (UR's published standard DH, rewritten: a2, a3 < 0 for the UR family).
UrAnalyticIk::UrAnalyticIk(const RobotModel& robot) {
  const auto& j = robot.spec().joints;
  const double h = M_PI / 2;
  const bool shape = j.size() == 6 && near(j[0].a, 0) && near(j[0].alpha, 0) && near(j[1].a, 0) && near(j[1].d, 0) &&
                     near(j[1].alpha, h) && near(j[2].d, 0) && near(j[2].alpha, 0) && near(j[3].alpha, 0) &&
                     near(j[4].a, 0) && near(j[4].alpha, h) && near(j[5].a, 0) && near(j[5].alpha, -h) &&
                     !near(j[2].a, 0) && !near(j[3].a, 0);
  bool z_axes = true;
  for (const JointSpec& js : j) z_axes = z_axes && js.dh;  // a, d, alpha mean something only in DH form
  for (int k = 0; k < robot.dof() && k < 6; ++k) z_axes = z_axes && robot.jointAxis(k).isApprox(Vec3::UnitZ(), 1e-12);
  if (!shape || !z_axes)
    throw InputError(robot.spec().file,
                     "analytic_ik: ur needs a UR-shaped modified DH chain (6 joints; alphas 0, pi/2, 0, 0, pi/2, -pi/2; "
                     "joints 2-4 parallel with non-zero a on joints 3 and 4; zero offsets elsewhere)");
  d1_ = j[0].d, a2_ = j[2].a, a3_ = j[3].a, d4_ = j[3].d, d5_ = j[4].d, d6_ = j[5].d;
  T_tcp_inv_ = robot.T_flange_tcp().inverse();
}

int UrAnalyticIk::solve(const Pose& T_base_tcp, double q6_singular, std::array<Joints, 8>& out) const {
  const Pose T = T_base_tcp * T_tcp_inv_;  // frame 6
  const Vec3 n = T.linear().col(0), o = T.linear().col(1), a = T.linear().col(2), p = T.translation();
  // Wrist centre (frame 5's origin): frame 6 lies d6 along the tool axis from it. Frames 2-4 turn
  // about y1's direction, and only d4 moves along it: p5 . y1 = -d4 with y1 = (-sin q1, cos q1, 0).
  const Vec3 p5 = p - d6_ * a;
  const double r = std::hypot(p5.x(), p5.y());
  // At the shoulder singularity r = |d4| (the two shoulder branches meet); rounding may put r
  // a hair below it.
  if (r < std::abs(d4_) - 1e-9 || r < 1e-12) return 0;
  const double psi = std::atan2(p5.y(), p5.x()), phi = std::asin(std::clamp(d4_ / r, -1.0, 1.0));
  int count = 0;
  for (const double q1 : {psi + phi, psi + M_PI - phi}) {
    const double s1 = std::sin(q1), c1 = std::cos(q1);
    const Vec3 y1(-s1, c1, 0);
    // The tool axis is frame 5's y: z6 . y1 = -cos q5.
    const double c5 = std::clamp(-a.dot(y1), -1.0, 1.0);
    const double q5a = std::atan2(a.cross(y1).norm(), c5);  // not acos: it resolves angles near 0 to 1e-8 only
    for (const double q5 : {q5a, -q5a}) {
      const double s5 = std::sin(q5);
      // y1 in frame 6 is (-cos q6 sin q5, sin q6 sin q5, -cos q5).
      double q6 = q6_singular;
      if (std::abs(s5) > 1e-9) {
        q6 = std::atan2(o.dot(y1) / s5, -n.dot(y1) / s5);
      } else {
        // Wrist singularity (axes 4 and 6 in line): only q4 + q6 is fixed, and the split decides
        // where frame 4's origin lies, on a circle of radius d5 about the wrist centre in the arm's
        // plane. Keep the given q6 when the elbow reaches that origin; else take the nearest split
        // that it reaches. Frame 5's z in frame 6 is (-sin q6, -cos q6, 0) whatever q5.
        const Mat3 R02 = Eigen::AngleAxisd(q1, Vec3::UnitZ()).toRotationMatrix() * Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()).toRotationMatrix();
        const Vec3 P = R02.transpose() * (p5 - Vec3(0, 0, d1_));  // wrist centre in frame 2 (z = d4)
        const Vec3 z5_given = R02.transpose() * (T.linear() * Vec3(-std::sin(q6), -std::cos(q6), 0));
        const double rp = std::hypot(P.x(), P.y()), tp = std::atan2(P.y(), P.x());
        const double rmin = std::abs(std::abs(a2_) - std::abs(a3_)), rmax = std::abs(a2_) + std::abs(a3_);
        // |o4|^2 = rp^2 + d5^2 - 2 d5 rp cos(phi - tp), o4 = P - d5 u(phi).
        if (rp > 1e-12 && d5_ > 1e-12) {
          const double phi_given = std::atan2(z5_given.y(), z5_given.x());
          const double c_given = std::cos(phi_given - tp);
          const double c_lo = (rp * rp + d5_ * d5_ - rmax * rmax) / (2 * d5_ * rp);  // cos >= c_lo reaches
          const double c_hi = (rp * rp + d5_ * d5_ - rmin * rmin) / (2 * d5_ * rp);  // cos <= c_hi reaches
          if (c_given < c_lo - 1e-12 || c_given > c_hi + 1e-12) {
            const double c = std::clamp(c_given < c_lo ? c_lo : c_hi, -1.0, 1.0);
            const double d = std::acos(c);
            const double phi5 = std::abs(std::remainder(tp + d - phi_given, 2 * M_PI)) <
                                        std::abs(std::remainder(tp - d - phi_given, 2 * M_PI))
                                    ? tp + d
                                    : tp - d;
            const Vec3 z5 = T.linear().transpose() * (R02 * Vec3(std::cos(phi5), std::sin(phi5), 0));
            q6 = std::atan2(-z5.x(), -z5.y());
          }
        }
      }
      // Frame 4 from frame 6 back through joints 6 and 5, then seen from frame 2's plane.
      const Pose T_0_1 = makePose(Vec3(0, 0, d1_), Eigen::AngleAxisd(q1, Vec3::UnitZ()).toRotationMatrix());
      const Mat3 Rx_p = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()).toRotationMatrix();
      const Pose T_4_5 = makePose(Vec3::Zero(), Rx_p * Eigen::AngleAxisd(q5, Vec3::UnitZ()).toRotationMatrix()) *
                         makePose(Vec3(0, 0, d5_), Mat3::Identity());
      const Pose T_5_6 = makePose(Vec3::Zero(), Rx_p.transpose() * Eigen::AngleAxisd(q6, Vec3::UnitZ()).toRotationMatrix()) *
                         makePose(Vec3(0, 0, d6_), Mat3::Identity());
      // M = Rz(q2) Tx(a2) Rz(q3) Tx(a3) Rz(q4) Tz(d4): planar, translation (a2 c2 + a3 c23, a2 s2 + a3 s23, d4).
      const Pose M = makePose(Vec3::Zero(), Rx_p.transpose()) * T_0_1.inverse() * T * (T_4_5 * T_5_6).inverse();
      const double x = M.translation().x(), y = M.translation().y();
      const double c3 = (x * x + y * y - a2_ * a2_ - a3_ * a3_) / (2 * a2_ * a3_);
      if (std::abs(c3) > 1 + 1e-7) continue;  // out of reach (a hair past: the stretched elbow, rounded)
      const double q3a = std::acos(std::clamp(c3, -1.0, 1.0));
      const double q234 = std::atan2(M.linear()(1, 0), M.linear()(0, 0));
      for (const double q3 : {q3a, -q3a}) {
        const double q2 = std::atan2(y, x) - std::atan2(a3_ * std::sin(q3), a2_ + a3_ * std::cos(q3));
        Joints q;
        q << wrapPi(q1), wrapPi(q2), wrapPi(q3), wrapPi(q234 - q2 - q3), wrapPi(q5), wrapPi(q6);
        out[count++] = q;
        if (q3a < 1e-12) break;  // one elbow solution when the arm is stretched
      }
    }
  }
  return count;
}

}  // namespace mm
