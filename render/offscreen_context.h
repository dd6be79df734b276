#pragma once
// An offscreen OpenGL context on OSMesa (Mesa's software rasterizer): no X server, no display.
//
// The context renders into a buffer it owns; Bind(cols, rows) (re)binds it at a size and makes it
// current on the calling thread, ReadBgr() returns what was drawn as an 8-bit BGR image with row 0
// at the top (OpenCV order; GL's bottom-up rows are flipped here, once).
//
// Determinism: no multisampling, no dithering, fixed GL state; Mesa's llvmpipe computes every
// pixel the same way on every run, so the same drawing gives the same bytes.
//
// Thread safety: a context may be used by one thread at a time (OpenGL's current-context rule).
// Several contexts may live in one process.

#include <memory>

#include <opencv2/core/mat.hpp>

namespace lcv::render {

// Mesa's compile-time limit on an OSMesa buffer's width and height, px.
inline constexpr int kMaxOffscreenSide = 16384;

class OffscreenContext {
 public:
  // Creates an RGBA context with a 24-bit depth buffer. Throws std::runtime_error when OSMesa
  // cannot create one (out of memory, broken Mesa installation).
  OffscreenContext();
  ~OffscreenContext();
  OffscreenContext(const OffscreenContext&) = delete;
  OffscreenContext& operator=(const OffscreenContext&) = delete;

  // Makes the context current on this thread, drawing into a cols x rows buffer, and sets the
  // viewport to the whole buffer. Precondition: 0 < cols, rows <= MaxSize().
  void Bind(int cols, int rows);
  // Largest width or height OSMesa accepts.
  int MaxSize() const;
  // The colour buffer of the last Bind, after glFinish: CV_8UC3 BGR, top row first.
  cv::Mat ReadBgr();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lcv::render
