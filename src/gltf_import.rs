//! glTF 2.0 import into a [`Scene`].
//!
//! What comes in: the chosen scene's node hierarchy with local TRS; meshes
//! (every triangle primitive becomes a submesh of one [`Geometry`], with its
//! own material); metallic-roughness materials with base-colour,
//! metallic-roughness, normal and emissive textures and their samplers,
//! alpha mode and cutoff, double-sidedness;
//! `KHR_lights_punctual` lights; cameras (as [`GltfCamera`]s an application
//! can register as views). Nodes with a negative scale are imported as they
//! are: ScenePrep flips the winding of mirrored draws.
//!
//! What is left out (with a warning, never a panic): primitives that are not
//! triangle lists, skins and morph targets, animations, texture coordinate
//! sets other than 0. Missing normals are generated (area-weighted smooth
//! normals); missing texture coordinates are zero.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{DVec3, Quat, UVec2, Vec2, Vec3, Vec4};
use oxygen_core::{
    Aabb, AlphaMode, Camera, ColorSpace, Filter, Geometry, GeometryHandle, Light, LightKind, Material, MaterialHandle,
    NodeKey, Projection, Renderable, ResolvedView, Sampling, Scene, Submesh, TextureHandle, TextureImage, Transform,
    Vertex, ViewContext, ViewError, ViewResolver, Wrap,
};
use thiserror::Error;
use tracing::{info_span, warn};

/// Why a glTF file could not be imported. Every variant names the file.
#[derive(Debug, Error)]
pub enum GltfError {
    /// The file could not be read or parsed, or a buffer or image it refers to is missing or malformed.
    #[error("{path}: {source}")]
    Load {
        /// The file.
        path: PathBuf,
        /// The gltf crate's reason.
        source: gltf::Error,
    },
    /// The requested scene does not exist.
    #[error("{path}: no scene {wanted} (the file has {available})")]
    NoSuchScene {
        /// The file.
        path: PathBuf,
        /// What was asked for.
        wanted: String,
        /// The scenes it has.
        available: String,
    },
    /// A mesh or texture inside the file is invalid.
    #[error("{path}: {what}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
}

/// Which of a file's scenes to import.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum SceneChoice {
    /// The file's default scene, or its first.
    #[default]
    Default,
    /// By index.
    Index(usize),
    /// By name.
    Name(String),
}

/// A camera found in the file, attached to a node.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfCamera {
    /// The camera's (or its node's) name.
    pub name: String,
    /// The node it follows.
    pub node: NodeKey,
    /// Its projection.
    pub camera: Camera,
    /// The aspect ratio the file asks for, if any.
    pub aspect_ratio: Option<f32>,
}

impl GltfCamera {
    /// A resolver that renders through this camera at `viewport` pixels.
    pub fn resolver(&self, viewport: UVec2) -> NodeCameraResolver {
        NodeCameraResolver { node: self.node, camera: self.camera, viewport }
    }
}

/// A view that follows a scene node: its world transform (scale removed) is
/// the camera pose, looking down the node's −Z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeCameraResolver {
    /// The node.
    pub node: NodeKey,
    /// The projection.
    pub camera: Camera,
    /// Target size.
    pub viewport: UVec2,
}

impl ViewResolver for NodeCameraResolver {
    fn resolve(&self, ctx: &ViewContext, scene: &Scene) -> Result<ResolvedView, ViewError> {
        let view_id = ctx.view_id;
        let world = scene
            .world_transform(self.node)
            .ok_or_else(|| ViewError::Other { view: view_id, message: "the camera's node was removed".into() })?;
        let (_, rotation, translation) = world.to_scale_rotation_translation();
        let pose = glam::DMat4::from_rotation_translation(rotation.normalize(), translation);
        let aspect = self.viewport.x as f32 / self.viewport.y.max(1) as f32;
        let projection =
            self.camera.projection_matrix(aspect).map_err(|source| ViewError::Camera { view: view_id, source })?;
        let (near, far) = self.camera.depth_range();
        ResolvedView::new_f64(view_id, pose.inverse(), projection, self.viewport, near, far)
    }
}

/// What an import produced.
#[derive(Debug, Default)]
pub struct GltfImport {
    /// Root nodes added to the scene.
    pub roots: Vec<NodeKey>,
    /// Cameras, in file order.
    pub cameras: Vec<GltfCamera>,
    /// Lights added.
    pub lights: usize,
    /// Renderable nodes added.
    pub renderables: usize,
    /// World-space bounds of every imported renderable.
    pub bounds: Option<Aabb>,
    /// What was skipped or approximated, one line each.
    pub warnings: Vec<String>,
}

struct Importer<'a> {
    path: &'a Path,
    buffers: &'a [gltf::buffer::Data],
    images: &'a [gltf::image::Data],
    textures: HashMap<(usize, bool), TextureHandle>,
    materials: HashMap<Option<usize>, MaterialHandle>,
    meshes: HashMap<usize, Option<(GeometryHandle, Vec<MaterialHandle>)>>,
    out: GltfImport,
}

/// Imports a `.gltf` or `.glb` file (with its buffers and images) into `scene`.
pub fn import_gltf(scene: &mut Scene, path: impl AsRef<Path>, choice: &SceneChoice) -> Result<GltfImport, GltfError> {
    let path = path.as_ref();
    let _span = info_span!("gltf_import", path = %path.display()).entered();
    // gltf-json 1.4 indexes out of bounds while validating some malformed
    // files (e.g. an accessor index past the end); turn that panic into the
    // error it should have been.
    let loaded = std::panic::catch_unwind(|| gltf::import(path)).map_err(|panic| {
        let reason = panic
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| panic.downcast_ref::<&str>().map(|s| (*s).to_owned()))
            .unwrap_or_else(|| "unknown".into());
        GltfError::Invalid { path: path.to_owned(), what: format!("malformed file (the validator failed: {reason})") }
    })?;
    let (document, buffers, images) = loaded.map_err(|source| GltfError::Load { path: path.to_owned(), source })?;
    let chosen = match choice {
        SceneChoice::Default => document.default_scene().or_else(|| document.scenes().next()),
        SceneChoice::Index(i) => document.scenes().nth(*i),
        SceneChoice::Name(name) => document.scenes().find(|s| s.name() == Some(name.as_str())),
    };
    let Some(gltf_scene) = chosen else {
        let available: Vec<String> =
            document.scenes().map(|s| format!("{} ({})", s.index(), s.name().unwrap_or("unnamed"))).collect();
        return Err(GltfError::NoSuchScene {
            path: path.to_owned(),
            wanted: format!("{choice:?}"),
            available: if available.is_empty() { "none".into() } else { available.join(", ") },
        });
    };
    let mut importer = Importer {
        path,
        buffers: &buffers,
        images: &images,
        textures: HashMap::new(),
        materials: HashMap::new(),
        meshes: HashMap::new(),
        out: GltfImport::default(),
    };
    for node in gltf_scene.nodes() {
        let key = importer.node(scene, &node, None, glam::DMat4::IDENTITY)?;
        importer.out.roots.push(key);
    }
    if document.animations().next().is_some() {
        importer.out.warnings.push("animations are not imported".into());
    }
    for w in &importer.out.warnings {
        warn!(path = %path.display(), "{w}");
    }
    Ok(importer.out)
}

fn convert_wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
    }
}

impl Importer<'_> {
    fn invalid(&self, what: String) -> GltfError {
        GltfError::Invalid { path: self.path.to_owned(), what }
    }

    fn node(
        &mut self,
        scene: &mut Scene,
        node: &gltf::Node<'_>,
        parent: Option<NodeKey>,
        parent_world: glam::DMat4,
    ) -> Result<NodeKey, GltfError> {
        let (t, r, s) = node.transform().decomposed();
        let rotation = Quat::from_array(r);
        let local = Transform {
            translation: Vec3::from(t),
            rotation: if rotation.is_finite() && rotation.length_squared() > 0.0 {
                rotation.normalize()
            } else {
                Quat::IDENTITY
            },
            scale: Vec3::from(s),
        };
        let name = node.name().map_or_else(|| format!("node {}", node.index()), str::to_owned);
        let key = match parent {
            Some(p) => scene.add_child(p, name.clone(), local).map_err(|e| self.invalid(e.to_string()))?,
            None => scene.add_node(name.clone(), local),
        };
        let world = parent_world * local.to_dmat4();

        if let Some(mesh) = node.mesh()
            && let Some((geometry, materials)) = self.mesh(scene, &mesh)?
        {
            if let Some(g) = scene.geometry(geometry) {
                let bounds = g.local_aabb().transformed(&world.as_mat4());
                self.out.bounds = Some(match self.out.bounds {
                    Some(b) => Aabb::new(b.min.min(bounds.min), b.max.max(bounds.max)),
                    None => bounds,
                });
            }
            scene.set_renderable(key, Renderable { geometry, materials }).map_err(|e| self.invalid(e.to_string()))?;
            self.out.renderables += 1;
        }
        if let Some(light) = node.light() {
            let color = Vec3::from(light.color());
            let range = light.range();
            let kind = match light.kind() {
                gltf::khr_lights_punctual::Kind::Directional => LightKind::Directional,
                gltf::khr_lights_punctual::Kind::Point => LightKind::Point { range },
                gltf::khr_lights_punctual::Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                    LightKind::Spot { range, inner_cone: inner_cone_angle, outer_cone: outer_cone_angle }
                }
            };
            let light = Light { kind, color, intensity: light.intensity(), ..Light::directional(1.0) };
            scene.set_light(key, Some(light)).map_err(|e| self.invalid(e.to_string()))?;
            self.out.lights += 1;
        }
        if let Some(camera) = node.camera() {
            let (projection, aspect_ratio) = match camera.projection() {
                gltf::camera::Projection::Perspective(p) => {
                    (Projection::Perspective { fov_y: p.yfov(), near: p.znear(), far: p.zfar() }, p.aspect_ratio())
                }
                gltf::camera::Projection::Orthographic(o) => (
                    Projection::Orthographic { half_height: o.ymag(), near: o.znear(), far: o.zfar() },
                    Some(o.xmag() / o.ymag()),
                ),
            };
            let camera_value = Camera { projection };
            scene.set_camera(key, Some(camera_value)).map_err(|e| self.invalid(e.to_string()))?;
            self.out.cameras.push(GltfCamera {
                name: camera.name().map_or(name.clone(), str::to_owned),
                node: key,
                camera: camera_value,
                aspect_ratio,
            });
        }
        if node.skin().is_some() {
            self.out.warnings.push(format!("node '{name}': skinning is not supported; drawn in bind pose"));
        }
        for child in node.children() {
            self.node(scene, &child, Some(key), world)?;
        }
        Ok(key)
    }

    fn mesh(
        &mut self,
        scene: &mut Scene,
        mesh: &gltf::Mesh<'_>,
    ) -> Result<Option<(GeometryHandle, Vec<MaterialHandle>)>, GltfError> {
        if let Some(done) = self.meshes.get(&mesh.index()) {
            return Ok(done.clone());
        }
        let name = mesh.name().map_or_else(|| format!("mesh {}", mesh.index()), str::to_owned);
        let mut vertices: Vec<Vertex> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut submeshes = Vec::new();
        let mut materials = Vec::new();
        for primitive in mesh.primitives() {
            if primitive.mode() != gltf::mesh::Mode::Triangles {
                self.out
                    .warnings
                    .push(format!("mesh '{name}': skipped a {:?} primitive (only triangles)", primitive.mode()));
                continue;
            }
            let reader = primitive.reader(|b| self.buffers.get(b.index()).map(|d| &d.0[..]));
            let Some(positions) = reader.read_positions() else {
                self.out.warnings.push(format!("mesh '{name}': skipped a primitive without positions"));
                continue;
            };
            let positions: Vec<Vec3> = positions.map(Vec3::from).collect();
            let base = vertices.len() as u32;
            let local_indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..positions.len() as u32).collect(),
            };
            if !local_indices.len().is_multiple_of(3) || local_indices.iter().any(|i| *i as usize >= positions.len()) {
                return Err(self.invalid(format!("mesh '{name}': primitive indices are not a valid triangle list")));
            }
            let normals: Vec<Vec3> = match reader.read_normals() {
                Some(n) => n.map(Vec3::from).collect(),
                None => {
                    self.out.warnings.push(format!("mesh '{name}': normals generated"));
                    generate_normals(&positions, &local_indices)
                }
            };
            let uvs: Vec<Vec2> = match reader.read_tex_coords(0) {
                Some(t) => t.into_f32().map(Vec2::from).collect(),
                None => vec![Vec2::ZERO; positions.len()],
            };
            for (i, p) in positions.iter().enumerate() {
                let n = normals.get(i).copied().unwrap_or(Vec3::Z);
                let uv = uvs.get(i).copied().unwrap_or(Vec2::ZERO);
                vertices.push(Vertex::new(*p, n, uv));
            }
            submeshes.push(Submesh { first_index: indices.len() as u32, index_count: local_indices.len() as u32 });
            indices.extend(local_indices.iter().map(|i| i + base));
            materials.push(self.material(scene, &primitive.material())?);
        }
        let result = if submeshes.is_empty() {
            None
        } else {
            let geometry =
                Geometry::new(name, vertices, indices, submeshes).map_err(|e| self.invalid(e.to_string()))?;
            Some((scene.add_geometry(geometry), materials))
        };
        self.meshes.insert(mesh.index(), result.clone());
        Ok(result)
    }

    fn material(&mut self, scene: &mut Scene, material: &gltf::Material<'_>) -> Result<MaterialHandle, GltfError> {
        if let Some(h) = self.materials.get(&material.index()) {
            return Ok(*h);
        }
        let pbr = material.pbr_metallic_roughness();
        let base_color_texture = match pbr.base_color_texture() {
            Some(info) => {
                if info.tex_coord() != 0 {
                    self.out.warnings.push("a base-colour texture uses texcoord set 1; set 0 is used".into());
                }
                Some(self.texture(scene, &info.texture(), ColorSpace::Srgb)?)
            }
            None => None,
        };
        let name = material.name().map_or_else(|| format!("material {:?}", material.index()), str::to_owned);
        let metallic_roughness_texture = match pbr.metallic_roughness_texture() {
            Some(info) => Some(self.texture(scene, &info.texture(), ColorSpace::Linear)?),
            None => None,
        };
        let (normal_texture, normal_scale) = match material.normal_texture() {
            Some(normal) => (Some(self.texture(scene, &normal.texture(), ColorSpace::Linear)?), normal.scale()),
            None => (None, 1.0),
        };
        let emissive_texture = match material.emissive_texture() {
            Some(info) => Some(self.texture(scene, &info.texture(), ColorSpace::Srgb)?),
            None => None,
        };
        let (occlusion_texture, occlusion_strength) = match material.occlusion_texture() {
            Some(occlusion) => {
                (Some(self.texture(scene, &occlusion.texture(), ColorSpace::Linear)?), occlusion.strength())
            }
            None => (None, 1.0),
        };
        let alpha_mode = match material.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask { cutoff: material.alpha_cutoff().unwrap_or(0.5) },
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        };
        let handle = scene.add_material(Material {
            name,
            base_color: Vec4::from(pbr.base_color_factor()),
            base_color_texture,
            metallic_roughness_texture,
            normal_texture,
            normal_scale,
            emissive: Vec3::from(material.emissive_factor()) * material.emissive_strength().unwrap_or(1.0),
            emissive_texture,
            occlusion_texture,
            occlusion_strength,
            metallic: pbr.metallic_factor(),
            roughness: pbr.roughness_factor(),
            alpha_mode,
            double_sided: material.double_sided(),
        });
        self.materials.insert(material.index(), handle);
        Ok(handle)
    }

    fn texture(
        &mut self,
        scene: &mut Scene,
        texture: &gltf::Texture<'_>,
        color_space: ColorSpace,
    ) -> Result<TextureHandle, GltfError> {
        let key = (texture.index(), color_space == ColorSpace::Srgb);
        if let Some(h) = self.textures.get(&key) {
            return Ok(*h);
        }
        let source = texture.source().index();
        let data =
            self.images.get(source).ok_or_else(|| self.invalid(format!("texture {} has no image", texture.index())))?;
        let rgba = to_rgba8(data)
            .ok_or_else(|| self.invalid(format!("image {source}: unsupported pixel format {:?}", data.format)))?;
        let sampler = texture.sampler();
        let sampling = Sampling {
            wrap: convert_wrap(sampler.wrap_s()),
            filter: match sampler.mag_filter() {
                Some(gltf::texture::MagFilter::Nearest) => Filter::Nearest,
                _ => Filter::Linear,
            },
        };
        if sampler.wrap_s() != sampler.wrap_t() {
            self.out
                .warnings
                .push(format!("texture {}: different wrap modes per axis; using the s mode", texture.index()));
        }
        let name = texture.name().map_or_else(|| format!("texture {}", texture.index()), str::to_owned);
        let image = TextureImage::new(name, data.width, data.height, color_space, rgba)
            .map_err(|e| self.invalid(e.to_string()))?
            .with_sampling(sampling);
        let handle = scene.add_texture(image);
        self.textures.insert(key, handle);
        Ok(handle)
    }
}

/// Area-weighted smooth normals (unit length; +Z where undefined).
fn generate_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut normals = vec![DVec3::ZERO; positions.len()];
    for tri in indices.chunks_exact(3) {
        let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        let n = (positions[b] - positions[a]).as_dvec3().cross((positions[c] - positions[a]).as_dvec3());
        for i in [a, b, c] {
            normals[i] += n;
        }
    }
    normals.into_iter().map(|n| n.as_vec3().try_normalize().unwrap_or(Vec3::Z)).collect()
}

/// Converts 8-bit images of 1–4 channels to RGBA8.
fn to_rgba8(data: &gltf::image::Data) -> Option<Vec<u8>> {
    use gltf::image::Format;
    let channels = match data.format {
        Format::R8 => 1,
        Format::R8G8 => 2,
        Format::R8G8B8 => 3,
        Format::R8G8B8A8 => 4,
        _ => return None,
    };
    let mut out = Vec::with_capacity(data.pixels.len() / channels * 4);
    for px in data.pixels.chunks_exact(channels) {
        out.extend_from_slice(&match channels {
            1 => [px[0], px[0], px[0], 255],
            2 => [px[0], px[0], px[0], px[1]],
            3 => [px[0], px[1], px[2], 255],
            _ => [px[0], px[1], px[2], px[3]],
        });
    }
    Some(out)
}
