#pragma once
// INTERNAL to render/*.cc: never include from a public header or outside render/.
//
// The OpenGL entry points the renderers use, fetched through OSMesaGetProcAddress. Calling gl*
// symbols directly would bind them to whichever libGL the dynamic linker saw first; when a binary
// also links VTK (or anything else pulling in glvnd's libGL), those calls go to a dispatch table
// with no current context and silently draw nothing (ARCHITECTURE.md). Going through OSMesa's own
// lookup always reaches the OSMesa context.

#include <GL/osmesa.h>

namespace lcv::render::internal {

// decltype(&::glX) only names the prototype from GL/gl.h; no symbol is referenced.
#define LCV_RENDER_GL_FUNCTIONS(X)                                                              \
  X(BindTexture) X(BlendFunc) X(Clear) X(ClearColor) X(ClearDepth) X(Color4ub) X(ColorPointer) \
  X(DeleteTextures) X(DepthFunc) X(DepthMask) X(Disable) X(DisableClientState) X(DrawArrays)   \
  X(Enable) X(EnableClientState) X(Finish) X(GenTextures) X(GetError) X(GetIntegerv)           \
  X(GetFloatv) X(GetString) X(Hint) X(LineWidth) X(LoadIdentity) X(LoadMatrixd) X(MatrixMode)  \
  X(PixelStorei) X(PointSize) X(ShadeModel) X(TexCoordPointer) X(TexEnvi) X(TexImage2D)        \
  X(TexParameterf) X(TexParameteri) X(VertexPointer) X(Viewport)

struct GlFunctions {
#define LCV_RENDER_GL_DECLARE(name) decltype(&::gl##name) name = nullptr;
  LCV_RENDER_GL_FUNCTIONS(LCV_RENDER_GL_DECLARE)
#undef LCV_RENDER_GL_DECLARE
  // glGenerateMipmap is GL 3.0; declared in glext.h only, so typed by hand.
  void (*GenerateMipmap)(GLenum target) = nullptr;
};

// The table for the OSMesa library loaded in this process. Valid only while an OSMesa context is
// current on the calling thread. Throws std::runtime_error when an entry point is missing.
const GlFunctions& Gl();

}  // namespace lcv::render::internal
