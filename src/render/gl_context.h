// An offscreen OpenGL context through EGL, with no window and no display server: a GPU's EGL
// device where one is present, else Mesa's surfaceless platform (llvmpipe on the CPU). One per
// process (a campaign's worker); MuJoCo renders into its own framebuffer, so no EGL surface is made.
#pragma once
#include <memory>
#include <string>

namespace mm {

class GlContext {
 public:
  /// Makes a context current on this thread. `platform`: auto (a hardware EGL device, else
  /// Mesa's surfaceless), device, surfaceless. Returns null with `why` said when none works.
  static std::unique_ptr<GlContext> create(const std::string& platform, std::string* why);
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  /// What renders: GL_RENDERER and GL_VERSION, and the EGL platform, e.g.
  /// "llvmpipe (LLVM 15.0.6, 256 bits); OpenGL 4.5 (Core Profile) Mesa 22.3.6; EGL surfaceless".
  const std::string& description() const { return description_; }

 private:
  GlContext() = default;
  void* display_ = nullptr;
  void* context_ = nullptr;
  std::string description_;
};

}  // namespace mm
