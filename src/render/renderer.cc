#include "render/renderer.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "render/gl_context.h"
#include "sim/sim_world.h"

namespace mm {

/// [m] The near clipping plane of every camera.
constexpr double kNearPlane = 0.01;
/// [m] The far plane's least distance (a cell whose geometry is not placed yet still shows).
constexpr double kMinFarPlane = 5.0;

struct Renderer::Impl {
  std::unique_ptr<GlContext> gl;
  const mjModel* model = nullptr;  // the model the scene and context below were made for
  uint64_t model_serial = 0;       // and its number (a pointer may be reused by a later model)
  mjvScene scene;
  mjrContext context;
  mjvOption option;
  int width = 0, height = 0;       // the offscreen buffer's size
  std::vector<uint8_t> rgb_scratch;
  std::vector<float> depth_scratch;

  Impl() {
    mjv_defaultScene(&scene);
    mjr_defaultContext(&context);
    mjv_defaultOption(&option);
    // What a real camera sees: geoms only (no sites, frames, joints or contact markers).
    for (int g = 0; g < mjNGROUP; ++g) option.sitegroup[g] = 0;
  }
  ~Impl() { release(); }

  // Drops from the scene every geom whose segmentation label is not `label` (the others' order kept).
  void keepOnly(const SimWorld& world, int label) {
    const std::vector<unsigned char>& labels = world.geomLabels();
    int kept = 0;
    for (int i = 0; i < scene.ngeom; ++i) {
      const mjvGeom& g = scene.geoms[i];
      if (g.objtype == mjOBJ_GEOM && g.objid >= 0 && g.objid < static_cast<int>(labels.size()) &&
          labels[static_cast<size_t>(g.objid)] == label)
      {
        scene.geoms[kept] = g;
        scene.geoms[kept].segid = kept;  // the segmentation's colours number the geoms drawn
        scene.geoms[kept].rgba[3] = 1;   // opaque: a transparent geom writes no depth
        ++kept;
      }
    }
    scene.ngeom = kept;
  }

  // The near and far clipping planes from the cell: MuJoCo scales both by the model's extent
  // (near = znear * extent), and the extent covers every body at compile time, objects parked far
  // below the floor included; with them, nothing nearer than about a metre was drawn. Here the far
  // plane reaches past the farthest point of the static scene and the robot (geoms' bounding
  // spheres, from here and every camera), and the near plane is a centimetre: a wrist camera sees
  // the fingers a few centimetres away. The depth buffer's resolution stays well under a
  // millimetre across the cell (24 bits: dz ~ z^2 / (near * 2^24), 6 um at 1 m).
  static void setClipPlanes(const SimWorld& world) {
    const mjModel* m = world.mujocoModel();
    const mjData* d = world.mujocoData();
    const std::vector<unsigned char>& labels = world.geomLabels();
    double lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9};
    for (int g = 0; g < m->ngeom; ++g) {
      const unsigned label = g < static_cast<int>(labels.size()) ? labels[static_cast<size_t>(g)] : unsigned{kSegmentScene};
      if (label != kSegmentScene && label != kSegmentRobot) continue;  // objects and obstacles may be parked anywhere
      const double r = m->geom_type[g] == mjGEOM_PLANE ? 0.0 : m->geom_rbound[g];
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], d->geom_xpos[3 * g + k] - r);
        hi[k] = std::max(hi[k], d->geom_xpos[3 * g + k] + r);
      }
    }
    double far = 1.0;
    for (int c = 0; c < m->ncam; ++c)
      for (int corner = 0; corner < 8; ++corner) {
        double dist2 = 0;
        for (int k = 0; k < 3; ++k) {
          const double x = (corner >> k & 1) ? hi[k] : lo[k];
          dist2 += (x - d->cam_xpos[3 * c + k]) * (x - d->cam_xpos[3 * c + k]);
        }
        far = std::max(far, std::sqrt(dist2));
      }
    auto* mutable_model = const_cast<mjModel*>(m);  // visual settings only: the physics never reads them
    const double extent = m->stat.extent > 0 ? m->stat.extent : 1.0;
    mutable_model->vis.map.znear = static_cast<float>(kNearPlane / extent);
    mutable_model->vis.map.zfar = static_cast<float>(std::max(kMinFarPlane, 1.5 * far) / extent);
  }
  void release() {
    if (!model) return;
    mjr_freeContext(&context);
    mjv_freeScene(&scene);
    model = nullptr;
  }

  // The scene and GPU context for `world`'s model, with an offscreen buffer of at least w x h.
  void prepare(const SimWorld& world, int w, int h) {
    const mjModel* m = world.mujocoModel();
    if (m == model && world.modelSerial() == model_serial && w <= width && h <= height) return;
    release();
    setClipPlanes(world);
    // The offscreen buffer's size and sampling are the model's visual settings, read by
    // mjr_makeContext; the physics never reads them. No multisampling: a pixel's colour, depth
    // and label come from the same surface, so edges do not blend labels.
    auto* mutable_model = const_cast<mjModel*>(m);
    width = std::max(w, m->vis.global.offwidth);
    height = std::max(h, m->vis.global.offheight);
    mutable_model->vis.global.offwidth = width;
    mutable_model->vis.global.offheight = height;
    mutable_model->vis.quality.offsamples = 0;
    mjv_makeScene(m, &scene, 4000);
    mjr_makeContext(m, &context, mjFONTSCALE_100);
    mjr_setBuffer(mjFB_OFFSCREEN, &context);
    model = m;
    model_serial = world.modelSerial();
  }
};

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {}
Renderer::~Renderer() = default;

std::unique_ptr<Renderer> Renderer::create(const std::string& egl, std::string* why) {
  auto gl = GlContext::create(egl, why);
  if (!gl) return nullptr;
  installMujocoHandlers();
  std::unique_ptr<Renderer> r(new Renderer);
  r->impl_->gl = std::move(gl);
  return r;
}

const std::string& Renderer::description() const { return impl_->gl->description(); }

namespace {

Pose cameraPose(const mjData* d, int cam) {
  // MuJoCo's camera frame (x right, y up, looking along -z) to OpenCV's (x right, y down, along +z).
  Pose T = Pose::Identity();
  for (int r = 0; r < 3; ++r) {
    T.translation()[r] = d->cam_xpos[3 * cam + r];
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = d->cam_xmat[9 * cam + 3 * r + c];
  }
  T.linear().col(1) *= -1;
  T.linear().col(2) *= -1;
  return T;
}

}  // namespace

CameraModel Renderer::camera(const SimWorld& world, const std::string& name, int width, int height,
                             const std::string& file, const std::string& key) const {
  const mjModel* m = world.mujocoModel();
  const int cam = mj_name2id(m, mjOBJ_CAMERA, name.c_str());
  if (cam < 0) {
    std::string names;
    for (int i = 0; i < m->ncam; ++i) names += std::string(names.empty() ? "" : ", ") + mj_id2name(m, mjOBJ_CAMERA, i);
    throw InputError(file, key + ": the scene has no camera '" + name + "' (expected one of: " +
                               (names.empty() ? "none defined" : names) + ")");
  }
  CameraModel c;
  c.name = name;
  c.width = width;
  c.height = height;
  // MuJoCo's fovy is the vertical field of view [deg]; pixels are square.
  c.fy = 0.5 * height / std::tan(0.5 * m->cam_fovy[cam] * M_PI / 180.0);
  c.fx = c.fy;
  c.cx = 0.5 * (width - 1);
  c.cy = 0.5 * (height - 1);
  mj_camlight(m, world.mujocoData());  // a camera on a moved body (a wrist camera) where the body is now
  c.T_world_camera = cameraPose(world.mujocoData(), cam);
  return c;
}

Frame Renderer::render(const SimWorld& world, const CameraModel& camera, unsigned kinds, int only_label) {
  Impl& I = *impl_;
  const mjModel* m = world.mujocoModel();
  mjData* d = world.mujocoData();
  const int w = camera.width, h = camera.height;
  I.prepare(world, w, h);
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  cam.type = mjCAMERA_FIXED;
  cam.fixedcamid = mj_name2id(m, mjOBJ_CAMERA, camera.name.c_str());
  mj_camlight(m, d);  // cameras and lights where their bodies are now (derived quantities only)
  Frame f;
  f.camera = camera;
  f.camera.T_world_camera = cameraPose(d, cam.fixedcamid);
  // A camera knocked off its mount draws from where it is; the frame reports the mount's pose
  // (mj_camlight recomputes the derived pose at the next step or render).
  const Pose offset = world.cameraOffset(cam.fixedcamid);
  if (offset.matrix() != Pose::Identity().matrix()) {
    Pose T = f.camera.T_world_camera * offset;
    T.linear().col(1) *= -1;
    T.linear().col(2) *= -1;
    for (int r = 0; r < 3; ++r) {
      d->cam_xpos[3 * cam.fixedcamid + r] = T.translation()[r];
      for (int c = 0; c < 3; ++c) d->cam_xmat[9 * cam.fixedcamid + 3 * r + c] = T.linear()(r, c);
    }
  }
  f.time = d->time;
  const mjrRect viewport = {0, 0, w, h};
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
  // OpenGL's rows run bottom-up; ours top-down.
  auto flip_rows = [&](const auto* src, auto* dst, int channels) {
    const size_t row = static_cast<size_t>(w) * static_cast<size_t>(channels);
    for (int r = 0; r < h; ++r) std::copy_n(src + static_cast<size_t>(h - 1 - r) * row, row, dst + static_cast<size_t>(r) * row);
  };
  I.rgb_scratch.resize(3 * n);
  I.depth_scratch.resize(n);
  if (kinds & (kRgb | kDepth)) {
    I.scene.flags[mjRND_SEGMENT] = 0;
    I.scene.flags[mjRND_IDCOLOR] = 0;
    mjv_updateScene(m, d, &I.option, nullptr, &cam, mjCAT_ALL, &I.scene);
    if (only_label >= 0) I.keepOnly(world, only_label);
    mjr_render(viewport, &I.scene, &I.context);
    mjr_readPixels((kinds & kRgb) ? I.rgb_scratch.data() : nullptr, (kinds & kDepth) ? I.depth_scratch.data() : nullptr,
                   viewport, &I.context);
    if (kinds & kRgb) {
      f.rgb.resize(3 * n);
      flip_rows(I.rgb_scratch.data(), f.rgb.data(), 3);
    }
    if (kinds & kDepth) {
      // The depth buffer holds d = (1/near - 1/z) / (1/near - 1/far) for a perspective
      // projection; z = near / (1 - d (1 - near/far)). The far plane (d = 1): nothing hit.
      const double near = I.scene.camera[0].frustum_near, far = I.scene.camera[0].frustum_far;
      f.depth.resize(n);
      flip_rows(I.depth_scratch.data(), f.depth.data(), 1);
      for (float& z : f.depth)
        z = z >= 1.0f ? 0.0f : static_cast<float>(near / (1.0 - z * (1.0 - near / far)));
    }
  }
  if (kinds & kSegmentation) {
    // Each geom drawn in a flat colour encoding its index in the scene plus one.
    I.scene.flags[mjRND_SEGMENT] = 1;
    I.scene.flags[mjRND_IDCOLOR] = 1;
    mjv_updateScene(m, d, &I.option, nullptr, &cam, mjCAT_ALL, &I.scene);
    if (only_label >= 0) I.keepOnly(world, only_label);
    mjr_render(viewport, &I.scene, &I.context);
    mjr_readPixels(I.rgb_scratch.data(), nullptr, viewport, &I.context);
    I.scene.flags[mjRND_SEGMENT] = 0;
    I.scene.flags[mjRND_IDCOLOR] = 0;
    const std::vector<unsigned char>& labels = world.geomLabels();
    std::vector<uint8_t> by_segid(static_cast<size_t>(I.scene.ngeom) + 1, kSegmentScene);
    for (int i = 0; i < I.scene.ngeom; ++i) {
      const mjvGeom& g = I.scene.geoms[i];
      if (g.segid >= 0 && g.segid < I.scene.ngeom && g.objtype == mjOBJ_GEOM && g.objid >= 0 &&
          g.objid < static_cast<int>(labels.size()))
        by_segid[static_cast<size_t>(g.segid) + 1] = labels[static_cast<size_t>(g.objid)];
    }
    std::vector<uint8_t> flat(n);
    for (size_t i = 0; i < n; ++i) {
      const size_t id = I.rgb_scratch[3 * i] + (I.rgb_scratch[3 * i + 1] << 8) + (I.rgb_scratch[3 * i + 2] << 16);
      flat[i] = id < by_segid.size() ? by_segid[id] : static_cast<uint8_t>(kSegmentScene);
    }
    f.segmentation.resize(n);
    flip_rows(flat.data(), f.segmentation.data(), 1);
  }
  if (offset.matrix() != Pose::Identity().matrix()) mj_camlight(m, d);  // the derived pose back on its mount for other readers
  return f;
}

}  // namespace mm
