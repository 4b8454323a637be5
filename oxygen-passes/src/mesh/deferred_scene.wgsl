// The per-view constants of deferred shading (mesh/deferred.wgsl): one
// compute pass shades the pixels of many cameras, so `scene` is not a
// uniform bound per camera but a private copy each invocation takes of its
// camera's slot (the compiler loads only the fields shading reads; a copy
// in workgroup memory, loaded by one invocation behind a barrier, cost an
// H200 0.2 ms more of a 256-view field). Composed in place of
// bindless/scene_constants.wgsl, so that the shading code reads `scene` as
// it does in the forward pass.

#include "bindless/CameraConstants"
#include "bindless/RendererConstants"
#include "bindless/SceneConstants"

var<private> scene: SceneConstants;
