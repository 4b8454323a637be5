//! The texture path policy: which binding model a device gets, what it
//! needs, and the WGSL that samples a texture slot under it.
//!
//! The path is chosen once, at device creation ([`TexturePath::best_for`]);
//! the heap builds its bind group for it and every mesh shader includes its
//! [`TexturePath::wgsl_sampling`] and [`TexturePath::wgsl_bindings`].

use super::tables::{GROUPED_SAMPLERS, GROUPS, SAMPLERS};

/// Texture slots a binding array holds.
pub const MAX_TEXTURES: u32 = 256;

const BINDING_ARRAY_WGSL: &str = include_str!("binding_array.wgsl");
const GROUPED_ARRAYS_WGSL: &str = include_str!("grouped_arrays.wgsl");

/// How textures are bound.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TexturePath {
    /// One binding array indexed by slot.
    BindingArray,
    /// Texture arrays grouped by size class and colour space.
    GroupedArrays,
}

impl TexturePath {
    /// Device features the binding-array path needs.
    pub const BINDING_ARRAY_FEATURES: wgpu::Features = wgpu::Features::TEXTURE_BINDING_ARRAY
        .union(wgpu::Features::SAMPLED_TEXTURE_AND_STORAGE_BUFFER_ARRAY_NON_UNIFORM_INDEXING);

    /// Whether a device with these features and limits can use this path.
    pub fn is_supported(self, features: wgpu::Features, limits: &wgpu::Limits) -> bool {
        match self {
            TexturePath::GroupedArrays => true,
            TexturePath::BindingArray => {
                features.contains(Self::BINDING_ARRAY_FEATURES)
                    && limits.max_binding_array_elements_per_shader_stage >= MAX_TEXTURES
            }
        }
    }

    /// The binding array where supported, grouped arrays otherwise.
    pub fn best_for(features: wgpu::Features, limits: &wgpu::Limits) -> Self {
        if TexturePath::BindingArray.is_supported(features, limits) {
            TexturePath::BindingArray
        } else {
            TexturePath::GroupedArrays
        }
    }

    /// The WGSL of `sample_texture(slot, uv, duv_dx, duv_dy)` on this path,
    /// which returns opaque white for [`crate::INVALID_SLOT`]. The caller
    /// passes the UV's screen derivatives (taken in uniform control flow),
    /// which pick the mip level. A `.wgsl` file whose `#include` lines name
    /// what it reads, for oxygen-passes' shader composer to resolve (this
    /// crate sits below the composer, so it writes the names, not the
    /// text): `bindless/constants` ([`crate::wgsl_constants`]),
    /// `bindless/domains` ([`crate::DomainKind::wgsl_bindings`], for
    /// `texture_location_domain`) and its group-2 declarations,
    /// [`TexturePath::wgsl_bindings`], under
    /// [`TexturePath::wgsl_bindings_name`].
    pub const fn wgsl_sampling(self) -> &'static str {
        match self {
            TexturePath::BindingArray => BINDING_ARRAY_WGSL,
            TexturePath::GroupedArrays => GROUPED_ARRAYS_WGSL,
        }
    }

    /// The name [`TexturePath::wgsl_sampling`] includes
    /// [`TexturePath::wgsl_bindings`] by.
    pub const fn wgsl_bindings_name(self) -> &'static str {
        match self {
            TexturePath::BindingArray => "bindless/textures/binding_array/bindings",
            TexturePath::GroupedArrays => "bindless/textures/grouped_arrays/bindings",
        }
    }

    /// WGSL declarations of group 2 on this path: generated, because their
    /// count and bindings follow the heap's layout (`MAX_TEXTURES`, the
    /// sampler tables), which the heap builds its bind group from. The
    /// binding array's come with the `enable` directive they need.
    pub fn wgsl_bindings(self) -> String {
        match self {
            TexturePath::BindingArray => {
                let array = format!(
                    "enable wgpu_binding_array;\n\
                     @group(2) @binding(0) var texture_array: binding_array<texture_2d<f32>, {MAX_TEXTURES}>;\n"
                );
                array + &sampler_declarations(1, SAMPLERS)
            }
            TexturePath::GroupedArrays => {
                let arrays: String = (0..GROUPS)
                    .map(|g| format!("@group(2) @binding({g}) var texture_group_{g}: texture_2d_array<f32>;\n"))
                    .collect();
                arrays + &sampler_declarations(GROUPS as u32, GROUPED_SAMPLERS)
            }
        }
    }
}

fn sampler_declarations(first_binding: u32, count: u32) -> String {
    (0..count)
        .map(|k| format!("@group(2) @binding({}) var texture_sampler_{k}: sampler;\n", first_binding + k))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field is read through its generated constant, never a literal
    /// shift or mask (the constants' values are tested in `location`).
    #[test]
    fn the_grouped_wgsl_reads_the_location_bits_rust_writes() {
        let wgsl = TexturePath::GroupedArrays.wgsl_bindings() + TexturePath::GroupedArrays.wgsl_sampling();
        assert!(wgsl.contains("(location & TEXTURE_LOCATION_NEAREST_BIT)"), "nearest bit");
        assert!(wgsl.contains("location >> TEXTURE_LOCATION_SAMPLER_SHIFT"), "wrap bits");
        assert!(wgsl.contains("location & TEXTURE_LOCATION_LAYER_MASK"), "layer");
        assert!(wgsl.contains("(location >> TEXTURE_LOCATION_GROUP_SHIFT) & TEXTURE_LOCATION_GROUP_MASK"), "array");
        use crate::textures::location::BITS;
        for literal in [BITS.nearest_bit, BITS.sampler_shift, BITS.group_shift, BITS.layer_mask] {
            assert!(
                !wgsl.contains(&format!(">> {literal}u")) && !wgsl.contains(&format!("{literal:#x}u")),
                "{literal}"
            );
        }
        for g in 0..GROUPS {
            assert!(wgsl.contains(&format!("texture_group_{g}")), "group {g} declared");
            assert!(
                wgsl.contains(&format!(
                    "case {g}u: {{\n            let side = f32(textureDimensions(texture_group_{g}).x);"
                )),
                "group {g} sampled"
            );
        }
        assert!(!wgsl.contains(&format!("texture_group_{GROUPS}")));
    }

    #[test]
    fn the_binding_array_path_needs_its_features_and_enough_elements() {
        let enough = wgpu::Limits { max_binding_array_elements_per_shader_stage: MAX_TEXTURES, ..Default::default() };
        let too_few =
            wgpu::Limits { max_binding_array_elements_per_shader_stage: MAX_TEXTURES - 1, ..Default::default() };
        let features = TexturePath::BINDING_ARRAY_FEATURES;
        assert!(TexturePath::BindingArray.is_supported(features, &enough));
        assert!(!TexturePath::BindingArray.is_supported(features, &too_few));
        assert!(!TexturePath::BindingArray.is_supported(wgpu::Features::TEXTURE_BINDING_ARRAY, &enough));
        assert!(TexturePath::GroupedArrays.is_supported(wgpu::Features::empty(), &too_few));
        assert_eq!(TexturePath::best_for(features, &enough), TexturePath::BindingArray);
        assert_eq!(TexturePath::best_for(features, &too_few), TexturePath::GroupedArrays);
    }

    #[test]
    fn each_sampler_of_the_table_gets_its_own_binding() {
        let declared = sampler_declarations(3, 2);
        assert_eq!(
            declared,
            "@group(2) @binding(3) var texture_sampler_0: sampler;\n@group(2) @binding(4) var texture_sampler_1: sampler;\n"
        );
        let binding_array = TexturePath::BindingArray.wgsl_bindings() + TexturePath::BindingArray.wgsl_sampling();
        for k in 0..SAMPLERS {
            assert!(binding_array.contains(&format!("@binding({}) var texture_sampler_{k}: sampler;", 1 + k)));
            assert!(binding_array.contains(&format!(
                "case {k}u: {{ return textureSampleGrad(texture_array[slot], texture_sampler_{k},"
            )));
        }
        assert!(!binding_array.contains(&format!("texture_sampler_{SAMPLERS}")));
    }

    #[test]
    fn both_paths_declare_sample_texture() {
        for path in [TexturePath::BindingArray, TexturePath::GroupedArrays] {
            assert!(path.wgsl_sampling().contains(
                "fn sample_texture(slot: u32, uv: vec2<f32>, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> vec4<f32>"
            ));
            // The composer finds the declarations by the name this crate gives them.
            let include = format!("#include \"{}\"", path.wgsl_bindings_name());
            assert!(path.wgsl_sampling().lines().any(|l| l == include), "{path:?} includes its bindings");
        }
    }
}
