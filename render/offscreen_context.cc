#include "render/offscreen_context.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "mapping/io/shared_library.h"
#include "render/gl_functions.h"
#include "slam/util/error.h"

namespace lcv::render {
namespace internal {
namespace {

// OSMesa's entry points, from libOSMesa opened at run time (mapping/io/shared_library.h): linked,
// it and LLVM (its llvmpipe rasterizer) would cost every command ~50 MB at start, including
// the ones that never render.
struct OsMesaFunctions {
  decltype(&::OSMesaCreateContextExt) CreateContextExt = nullptr;
  decltype(&::OSMesaDestroyContext) DestroyContext = nullptr;
  decltype(&::OSMesaGetIntegerv) GetIntegerv = nullptr;
  decltype(&::OSMesaMakeCurrent) MakeCurrent = nullptr;
  decltype(&::OSMesaGetProcAddress) GetProcAddress = nullptr;
};

OsMesaFunctions LoadOsMesa() {
  // The soname of Mesa's OSMesa (Debian's libosmesa6); the unversioned name as a fallback for
  // installations with only the development link.
  const mapping::SharedLibrary library = mapping::SharedLibrary::Open(
      {"libOSMesa.so.8", "libOSMesa.so"}, "to render offscreen (Mesa's OSMesa, package libosmesa6)");
  OsMesaFunctions osmesa;
  osmesa.CreateContextExt =
      reinterpret_cast<decltype(osmesa.CreateContextExt)>(library.Symbol("OSMesaCreateContextExt"));
  osmesa.DestroyContext =
      reinterpret_cast<decltype(osmesa.DestroyContext)>(library.Symbol("OSMesaDestroyContext"));
  osmesa.GetIntegerv = reinterpret_cast<decltype(osmesa.GetIntegerv)>(library.Symbol("OSMesaGetIntegerv"));
  osmesa.MakeCurrent = reinterpret_cast<decltype(osmesa.MakeCurrent)>(library.Symbol("OSMesaMakeCurrent"));
  osmesa.GetProcAddress =
      reinterpret_cast<decltype(osmesa.GetProcAddress)>(library.Symbol("OSMesaGetProcAddress"));
  return osmesa;
}

const OsMesaFunctions& OsMesa() {
  static const OsMesaFunctions functions = LoadOsMesa();  // thread-safe initialization
  return functions;
}

GlFunctions LoadGlFunctions() {
  GlFunctions gl;
  std::string missing;
#define LCV_RENDER_GL_LOAD(name)                                                      \
  gl.name = reinterpret_cast<decltype(gl.name)>(OsMesa().GetProcAddress("gl" #name)); \
  if (!gl.name) missing += " gl" #name;
  LCV_RENDER_GL_FUNCTIONS(LCV_RENDER_GL_LOAD)
  LCV_RENDER_GL_LOAD(GenerateMipmap)
#undef LCV_RENDER_GL_LOAD
  if (!missing.empty()) {
    throw std::runtime_error("OSMesa lacks OpenGL entry points:" + missing);
  }
  return gl;
}

}  // namespace

const GlFunctions& Gl() {
  static const GlFunctions functions = LoadGlFunctions();
  return functions;
}

}  // namespace internal

struct OffscreenContext::Impl {
  OSMesaContext context = nullptr;
  std::vector<unsigned char> buffer;  // BGRA, bottom row first (GL order)
  int cols = 0;
  int rows = 0;
};

OffscreenContext::OffscreenContext() : impl_(std::make_unique<Impl>()) {
  // BGRA matches OpenCV's channel order; 24-bit depth, no stencil, no accumulation buffer.
  impl_->context = internal::OsMesa().CreateContextExt(OSMESA_BGRA, 24, 0, 0, nullptr);
  if (!impl_->context) throw std::runtime_error("OSMesa: cannot create an offscreen GL context");
}

OffscreenContext::~OffscreenContext() {
  if (impl_ && impl_->context) internal::OsMesa().DestroyContext(impl_->context);
}

int OffscreenContext::MaxSize() const {
  int max_width = 0, max_height = 0;
  internal::OsMesa().GetIntegerv(OSMESA_MAX_WIDTH, &max_width);
  internal::OsMesa().GetIntegerv(OSMESA_MAX_HEIGHT, &max_height);
  // Before the first MakeCurrent OSMesa may report 0: use Mesa's compile-time limit.
  if (max_width <= 0 || max_height <= 0) return kMaxOffscreenSide;
  return std::min(max_width, max_height);
}

void OffscreenContext::Bind(int cols, int rows) {
  LCV_CHECK(cols > 0 && rows > 0 && cols <= kMaxOffscreenSide && rows <= kMaxOffscreenSide)
      << cols << "x" << rows;
  if (cols != impl_->cols || rows != impl_->rows) {
    impl_->buffer.assign(static_cast<size_t>(cols) * rows * 4, 0);
    impl_->cols = cols;
    impl_->rows = rows;
  }
  if (!internal::OsMesa().MakeCurrent(impl_->context, impl_->buffer.data(), GL_UNSIGNED_BYTE, cols, rows)) {
    throw std::runtime_error("OSMesa: cannot bind a " + std::to_string(cols) + "x" +
                             std::to_string(rows) + " buffer");
  }
  const auto& gl = internal::Gl();
  gl.Viewport(0, 0, cols, rows);
  // Pinned state for determinism: no dithering, no multisampling.
  gl.Disable(GL_DITHER);
  gl.Disable(GL_MULTISAMPLE);
  gl.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
}

cv::Mat OffscreenContext::ReadBgr() {
  LCV_CHECK(impl_->cols > 0) << "ReadBgr before Bind";
  internal::Gl().Finish();
  const cv::Mat bgra(impl_->rows, impl_->cols, CV_8UC4, impl_->buffer.data());
  cv::Mat flipped, bgr;
  cv::flip(bgra, flipped, 0);  // GL rows are bottom-up
  cv::cvtColor(flipped, bgr, cv::COLOR_BGRA2BGR);
  return bgr;
}

}  // namespace lcv::render
