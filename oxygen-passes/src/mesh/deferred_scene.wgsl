// The per-view constants of deferred shading (mesh/deferred.wgsl): one
// compute pass shades the pixels of many cameras, so `scene` is not a
// uniform bound per camera but a copy in workgroup memory, loaded once by
// each workgroup (whose pixels are all of one camera's tile) from its
// camera's slot. Composed in place of bindless/scene_constants.wgsl, so
// that the shading code reads `scene` as it does in the forward pass.

#include "bindless/CameraConstants"
#include "bindless/RendererConstants"
#include "bindless/SceneConstants"

var<workgroup> scene: SceneConstants;
