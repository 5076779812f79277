// The physics step of a SimWorld: MuJoCo's split step with the contacts' velocity-product term
// between its halves, objects at rest put to sleep and woken, and the step's monitors.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "sim/midphase.h"
#include "sim/sim_world_impl.h"

namespace mm {

void SimWorld::Impl::addVelocityProduct() {
  if (!velocity_product || d->ncon == 0) return;
  const int nb = m->nbody;
  cacc_vp.assign(6 * static_cast<size_t>(nb), 0.0);
  vp_needed.assign(static_cast<size_t>(nb), 0);  // the bodies in a contact and their ancestors
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    if (c.exclude || c.efc_address < 0) continue;
    for (int b : {m->geom_bodyid[c.geom1], m->geom_bodyid[c.geom2]})
      for (; b > 0 && !vp_needed[static_cast<size_t>(b)]; b = m->body_parentid[b]) vp_needed[static_cast<size_t>(b)] = 1;
  }
  for (int b = 1; b < nb; ++b) {  // as mj_rne with qacc = 0 and no gravity: parents come first
    if (!vp_needed[static_cast<size_t>(b)]) continue;
    mjtNum* a = cacc_vp.data() + 6 * b;
    const mjtNum* ap = cacc_vp.data() + 6 * m->body_parentid[b];
    for (int k = 0; k < 6; ++k) a[k] = ap[k];
    for (int j = m->body_dofadr[b]; j < m->body_dofadr[b] + m->body_dofnum[b]; ++j)
      for (int k = 0; k < 6; ++k) a[k] += d->cdof_dot[6 * j + k] * d->qvel[j];
  }
  // A point's acceleration in the world frame (angular, linear), as mj_objectAcceleration turns
  // the com-based spatial acceleration into a point's: shift to the point, add omega x v.
  auto pointAcc = [&](int b, const mjtNum* p, mjtNum out[6]) {
    if (b == 0) {
      mju_zero(out, 6);
      return;
    }
    const mjtNum* com = d->subtree_com + 3 * m->body_rootid[b];
    mjtNum vel[6], corr[3];
    mju_transformSpatial(out, cacc_vp.data() + 6 * b, 0, p, com, nullptr);
    mju_transformSpatial(vel, d->cvel + 6 * b, 0, p, com, nullptr);
    mju_cross(corr, vel, vel + 3);
    mju_addTo3(out + 3, corr);
  };
  const bool elliptic = m->opt.cone == mjCONE_ELLIPTIC;
  const double h = m->opt.timestep;
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    if (c.exclude || c.efc_address < 0) continue;
    mjtNum a1[6], a2[6], rel[6];
    pointAcc(m->geom_bodyid[c.geom1], c.pos, a1);
    pointAcc(m->geom_bodyid[c.geom2], c.pos, a2);
    mju_sub(rel, a2, a1, 6);  // MuJoCo's contact rows are body 2's motion relative to body 1's
    // In the contact frame: normal, tangent 1, tangent 2 (linear), then torsion and rolling.
    const mjtNum comp[6] = {mju_dot3(c.frame, rel + 3),     mju_dot3(c.frame + 3, rel + 3),
                            mju_dot3(c.frame + 6, rel + 3), mju_dot3(c.frame, rel),
                            mju_dot3(c.frame + 3, rel),     mju_dot3(c.frame + 6, rel)};
    auto subtract = [&](int row, mjtNum jdot) {
      const mjtNum* kbip = d->efc_KBIP + 4 * row;
      const mjtNum imp = std::max(kbip[2], mjMINIMP);
      d->efc_aref[row] -= (1.0 / imp - 0.5 * kbip[1] * h) * jdot;
    };
    const int adr = c.efc_address;
    if (elliptic || c.dim == 1) {
      for (int r = 0; r < c.dim; ++r) subtract(adr + r, comp[r]);
    } else {  // pyramidal: edge rows J_normal +- friction_k J_k
      for (int k = 0; k < c.dim - 1; ++k) {
        subtract(adr + 2 * k, comp[0] + c.friction[k] * comp[k + 1]);
        subtract(adr + 2 * k + 1, comp[0] - c.friction[k] * comp[k + 1]);
      }
    }
  }
}

void SimWorld::Impl::initSleep() {
  const size_t n = obj_body.size();
  asleep.assign(n, 0);
  still.assign(n, 0);
  saved_contype.assign(n, 0);
  saved_conaffinity.assign(n, 0);
  mover_geoms.clear();
  for (int g = 0; g < m->ngeom; ++g)
    if (robot_geom[g] || foreign_geom[g]) mover_geoms.push_back(g);
}

void SimWorld::Impl::wake(size_t i) {
  if (i >= asleep.size() || !asleep[i]) return;
  const int b = obj_body[i];
  for (int g : obj_colliders[i]) {
    m->geom_contype[g] = saved_contype[i];
    m->geom_conaffinity[g] = saved_conaffinity[i];
  }
  std::fill(d->xfrc_applied + 6 * b, d->xfrc_applied + 6 * b + 6, 0.0);
  asleep[i] = 0;
  still[i] = 0;
}

void SimWorld::Impl::wakeAll() {
  for (size_t i = 0; i < asleep.size(); ++i) wake(i);
  std::fill(still.begin(), still.end(), 0);
}

bool SimWorld::Impl::moverNear(size_t i) const {
  auto near = [&](int g, int h) {  // bounding spheres first (cheap), then the shapes' gap bound
    const mjtNum* p = d->geom_xpos + 3 * g;
    const mjtNum* q = d->geom_xpos + 3 * h;
    const mjtNum dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
    const mjtNum r = m->geom_rbound[g] + m->geom_rbound[h] + kSleepGap;
    return dx * dx + dy * dy + dz * dz < r * r && geomGapLowerBound(m, d, g, h) < kSleepGap;
  };
  for (int g : obj_colliders[i]) {
    for (int h : mover_geoms)
      if (m->geom_type[h] != mjGEOM_PLANE && near(g, h)) return true;
    for (size_t j = 0; j < obj_colliders.size(); ++j)
      if (j != i && moving[j])
        for (int h : obj_colliders[j])
          if (near(g, h)) return true;
  }
  return false;
}

void SimWorld::Impl::updateSleep() {
  if (!sleep) return;
  const size_t n = obj_body.size();
  moving.assign(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const mjtNum* v = d->qvel + obj_dof[i];
    moving[i] = !asleep[i] && (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] >= 0.5e-3 * 0.5e-3 ||
                               v[3] * v[3] + v[4] * v[4] + v[5] * v[5] >= 5e-3 * 5e-3);
  }
  // Waking spreads at once: an object just woken counts as moving for its sleeping neighbours
  // (one resting against it may be pushed next).
  for (bool woke = true; woke;) {
    woke = false;
    for (size_t i = 0; i < n; ++i)
      if (asleep[i] && moverNear(i)) wake(i), moving[i] = 1, woke = true;
  }
  // Only an object resting on the static world sleeps: every contact with a static geom, its
  // normal within 25 degrees of vertical. One leaning on another object or against a wall is
  // held by friction, and MuJoCo's soft contacts let it creep on: freezing it there changed
  // dense bins (measured: 477 of 500 cubes placed against 490).
  supported.assign(n, 1);
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& con = d->contact[c];
    for (int side = 0; side < 2; ++side) {
      const int g = side ? con.geom2 : con.geom1, other = side ? con.geom1 : con.geom2;
      const int i = geom_object[g];
      if (i < 0) continue;
      const int b = m->geom_bodyid[other];
      const bool on_static = m->body_weldid[b] == 0 && m->body_mocapid[b] < 0;
      if (!on_static || std::abs(con.frame[2]) < 0.906) supported[static_cast<size_t>(i)] = 0;
    }
  }
  for (size_t i = 0; i < n; ++i) {
    if (asleep[i]) std::fill(d->qvel + obj_dof[i], d->qvel + obj_dof[i] + 6, 0.0);
    else still[i] = !moving[i] && supported[i] && !moverNear(i) ? still[i] + 1 : 0;
  }
  for (size_t i = 0; i < n; ++i)
    if (!asleep[i] && still[i] >= kSleepSteps) putToSleep(i);
}

void SimWorld::Impl::putToSleep(size_t i) {
  const int b = obj_body[i];
  saved_contype[i] = m->geom_contype[obj_geom[i]];  // an object's pieces collide alike
  saved_conaffinity[i] = m->geom_conaffinity[obj_geom[i]];
  for (int g : obj_colliders[i]) m->geom_contype[g] = m->geom_conaffinity[g] = 0;
  std::fill(d->qvel + obj_dof[i], d->qvel + obj_dof[i] + 6, 0.0);
  for (int k = 0; k < 3; ++k) d->xfrc_applied[6 * b + k] = -m->body_mass[b] * m->opt.gravity[k];
  asleep[i] = 1;
}

void SimWorld::Impl::saveGood() {
  auto keep = [](std::vector<mjtNum>& to, const mjtNum* from, int n) { to.assign(from, from + n); };
  keep(good.qpos, d->qpos, m->nq);
  keep(good.qvel, d->qvel, m->nv);
  keep(good.act, d->act, m->na);
  keep(good.ctrl, d->ctrl, m->nu);
  keep(good.mocap_pos, d->mocap_pos, 3 * m->nmocap);
  keep(good.mocap_quat, d->mocap_quat, 4 * m->nmocap);
  keep(good.xfrc_applied, d->xfrc_applied, 6 * m->nbody);
  keep(good.qacc_warmstart, d->qacc_warmstart, m->nv);
  good.time = d->time;
}

void SimWorld::Impl::restoreGood() {
  auto put = [](const std::vector<mjtNum>& from, mjtNum* to) { std::copy(from.begin(), from.end(), to); };
  put(good.qpos, d->qpos);
  put(good.qvel, d->qvel);
  put(good.act, d->act);
  put(good.ctrl, d->ctrl);
  put(good.mocap_pos, d->mocap_pos);
  put(good.mocap_quat, d->mocap_quat);
  put(good.xfrc_applied, d->xfrc_applied);
  put(good.qacc_warmstart, d->qacc_warmstart);
  d->time = good.time;
  mj_forward(m, d);
}

void SimWorld::Impl::physicsStep() {
  setMidphase(midphase);
  updateSleep();
  mj_step1(m, d);
  addVelocityProduct();
  mj_step2(m, d);
}

void SimWorld::Impl::monitor() {
  static const int kBad[] = {mjWARN_BADQPOS, mjWARN_BADQVEL, mjWARN_BADQACC, mjWARN_BADCTRL,
                             mjWARN_CONTACTFULL, mjWARN_CNSTRFULL};
  static const char* kNames[] = {"bad qpos", "bad qvel", "bad qacc", "bad ctrl", "contact buffer full",
                                 "constraint buffer full"};
  for (int k = 0; k < 6; ++k) {
    if (d->warning[kBad[k]].number > 0 && !unstable) {
      unstable = true;
      std::ostringstream s;
      s << "MuJoCo warning '" << kNames[k] << "' at t=" << d->time << " s";
      if (!lastMujocoWarning().empty()) s << ": " << lastMujocoWarning();
      instability = s.str();
    }
  }
  // A collision event is an episode of penetrating contact between the robot and the static
  // scene or an obstacle: its onset counts once, however many geoms touch, and bounces within 0.1 s of the
  // last contact belong to the same event.
  std::set<std::pair<int, int>> now;
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    if (c.dist > -1e-4) continue;  // touching within 0.1 mm is not a collision
    int r = -1, s = -1;
    const bool hard1 = static_geom[c.geom1] || foreign_geom[c.geom1], hard2 = static_geom[c.geom2] || foreign_geom[c.geom2];
    if (robot_geom[c.geom1] && hard2) r = c.geom1, s = c.geom2;
    else if (robot_geom[c.geom2] && hard1) r = c.geom2, s = c.geom1;
    if (r < 0) continue;
    now.insert({r, s});
  }
  if (!now.empty()) {
    if (d->time - last_contact_time > 0.1) {
      ++collision_events;
      std::ostringstream o;
      o << mj_id2name(m, mjOBJ_GEOM, now.begin()->first) << " hit " << mj_id2name(m, mjOBJ_GEOM, now.begin()->second)
        << " at t=" << d->time;
      if (collision_log.size() < 20) collision_log.push_back(o.str());
    }
    last_contact_time = d->time;
  }
  touching.swap(now);
}

}  // namespace mm
