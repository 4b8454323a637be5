//! Helpers shared by this crate's tests.

use oxygen_bindless::TexturePath;
use oxygen_passes::PassKind;

/// Every pass kind. The match has no wildcard: a new kind is a compile
/// error here until it is added to the array.
pub fn all_kinds() -> [PassKind; 7] {
    let kinds = [
        PassKind::DepthPrePass,
        PassKind::Shadow,
        PassKind::ShadingAfterPrePass,
        PassKind::Shading,
        PassKind::Transparent,
        PassKind::Labels,
        PassKind::Visibility,
    ];
    for kind in kinds {
        match kind {
            PassKind::DepthPrePass
            | PassKind::Shadow
            | PassKind::ShadingAfterPrePass
            | PassKind::Shading
            | PassKind::Transparent
            | PassKind::Labels
            | PassKind::Visibility => {}
        }
    }
    kinds
}

/// Every texture path, listed the same way as [`all_kinds`].
pub fn all_paths() -> [TexturePath; 2] {
    let paths = [TexturePath::BindingArray, TexturePath::GroupedArrays];
    for path in paths {
        match path {
            TexturePath::BindingArray | TexturePath::GroupedArrays => {}
        }
    }
    paths
}
