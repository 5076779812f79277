// The test suite's offscreen renderer: one per test process, made on first use (a test fails,
// saying why, when this machine cannot make an EGL context).
#pragma once
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "render/renderer.h"

namespace mm::testing_render {

inline Renderer& renderer() {
  static std::unique_ptr<Renderer> r = [] {
    std::string why;
    auto made = Renderer::create("auto", &why);
    if (!made) ADD_FAILURE() << "no offscreen OpenGL context: " << why;
    return made;
  }();
  return *r;
}

}  // namespace mm::testing_render
