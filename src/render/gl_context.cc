#include "render/gl_context.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/gl.h>

#include <cstdio>
#include <cstring>
#include <vector>

namespace mm {
namespace {

std::string eglErrorText() {
  char b[32];
  std::snprintf(b, sizeof b, "EGL error 0x%04x", static_cast<unsigned>(eglGetError()));
  return b;
}

bool hasExtension(const char* list, const char* name) {
  if (!list) return false;
  const size_t n = std::strlen(name);
  for (const char* p = std::strstr(list, name); p; p = std::strstr(p + 1, name))
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

// A context on `display` (initialized here), made current; false with `why` said otherwise.
bool makeCurrent(EGLDisplay display, EGLContext* context, std::string* why) {
  EGLint major = 0, minor = 0;
  if (!eglInitialize(display, &major, &minor)) {
    *why = "eglInitialize: " + eglErrorText();
    return false;
  }
  const EGLint attributes[] = {EGL_RED_SIZE,   8, EGL_GREEN_SIZE,      8,  EGL_BLUE_SIZE,  8, EGL_ALPHA_SIZE,
                               8,              EGL_DEPTH_SIZE,         24, EGL_STENCIL_SIZE, 8, EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE,
                               EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint n = 0;
  if (!eglChooseConfig(display, attributes, &config, 1, &n) || n < 1) {
    *why = "no EGL config with 8-bit RGBA, 24-bit depth and desktop OpenGL";
    return false;
  }
  if (!eglBindAPI(EGL_OPENGL_API)) {
    *why = "eglBindAPI(OpenGL): " + eglErrorText();
    return false;
  }
  // A compatibility context (no version asked): MuJoCo 2.2's renderer uses fixed-function OpenGL.
  *context = eglCreateContext(display, config, EGL_NO_CONTEXT, nullptr);
  if (*context == EGL_NO_CONTEXT) {
    *why = "eglCreateContext: " + eglErrorText();
    return false;
  }
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, *context)) {
    *why = "eglMakeCurrent without a surface: " + eglErrorText();
    eglDestroyContext(display, *context);
    return false;
  }
  return true;
}

}  // namespace

std::unique_ptr<GlContext> GlContext::create(const std::string& platform, std::string* why) {
  why->clear();
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  auto get_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (!client || !get_display) {
    *why = "EGL has no platform displays (EGL_EXT_platform_base): is libEGL (libegl1, libegl-mesa0) installed?";
    return nullptr;
  }
  std::string tried;
  auto note = [&](const std::string& what) { tried += (tried.empty() ? "" : "; ") + what; };
  std::unique_ptr<GlContext> c(new GlContext);
  EGLContext context = EGL_NO_CONTEXT;

  // 1. A hardware EGL device (a GPU), skipping Mesa's software device (surfaceless does that).
  if (platform != "surfaceless" && hasExtension(client, "EGL_EXT_platform_device")) {
    auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto device_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
    EGLDeviceEXT devices[16];
    EGLint n = 0;
    if (query_devices && query_devices(16, devices, &n)) {
      int hardware = 0;
      for (EGLint i = 0; i < n; ++i) {
        const char* ext = device_string ? device_string(devices[i], EGL_EXTENSIONS) : nullptr;
        if (hasExtension(ext, "EGL_MESA_device_software")) continue;
        ++hardware;
        EGLDisplay d = get_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
        std::string reason;
        if (d != EGL_NO_DISPLAY && makeCurrent(d, &context, &reason)) {
          c->display_ = d;
          c->description_ = "EGL device " + std::to_string(i);
          break;
        }
        note("EGL device " + std::to_string(i) + ": " + (reason.empty() ? eglErrorText() : reason));
      }
      if (!hardware) note("no hardware EGL device");
    }
  }
  // 2. Mesa's surfaceless platform: llvmpipe on the CPU (or Mesa's driver for the GPU).
  if (!c->display_ && platform != "device" && hasExtension(client, "EGL_MESA_platform_surfaceless")) {
    EGLDisplay d = get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    std::string reason;
    if (d != EGL_NO_DISPLAY && makeCurrent(d, &context, &reason)) {
      c->display_ = d;
      c->description_ = "EGL surfaceless";
    } else {
      note("Mesa surfaceless: " + (reason.empty() ? eglErrorText() : reason));
    }
  } else if (!c->display_ && platform != "device") {
    note("no EGL_MESA_platform_surfaceless (install libegl-mesa0)");
  }
  if (!c->display_) {
    *why = "no offscreen OpenGL context (render.egl " + platform + "): " + tried;
    return nullptr;
  }
  c->context_ = context;
  const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const auto* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  c->description_ = std::string(renderer ? renderer : "?") + "; OpenGL " + (version ? version : "?") + "; " + c->description_;
  return c;
}

GlContext::~GlContext() {
  if (!display_) return;
  eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  if (context_) eglDestroyContext(display_, context_);
  // The display is not terminated: EGL gives every caller in the process the same display for
  // the same platform and device, so terminating it would pull it from under another context (and
  // unloading Mesa's driver with it leaves the driver's allocations unreachable: LeakSanitizer
  // reports them).
}

}  // namespace mm
