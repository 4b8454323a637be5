//! View targets, tile atlases and label targets: the sizes the renderer
//! counts against its target budget before it allocates (on the CPU), and
//! the same figures, the tiles' places, the label planes and the targets'
//! fit read from targets allocated on the test adapter (lavapipe here).

use oxygen_gpu::{GpuContext, GpuOptions, HdrFormat, Label, LabelSet, LabelTargets, Msaa, TileAtlas, ViewTargets};

/// A device on the test adapter; fails (never skips) without one, as the
/// root crate's GPU tests do.
fn device() -> GpuContext {
    GpuContext::new_headless(&GpuOptions::default()).unwrap_or_else(|e| panic!("these tests need an adapter: {e}"))
}

/// A `side`² texture of `layers` layers to render into (a shadow atlas, a
/// probe's cube).
fn square_array(gpu: &GpuContext, side: u32, layers: u32, format: wgpu::TextureFormat) -> wgpu::Texture {
    let size = wgpu::Extent3d { width: side, height: side, depth_or_array_layers: layers };
    oxygen_gpu::texture_2d(&gpu.device, "layers", size, 1, format, wgpu::TextureUsages::RENDER_ATTACHMENT)
}

#[test]
fn msaa_settings_are_their_sample_counts_and_nothing_else() {
    for (msaa, samples) in [(Msaa::Off, 1), (Msaa::X2, 2), (Msaa::X4, 4)] {
        assert_eq!(msaa.samples(), samples);
        assert_eq!(Msaa::from_samples(samples), Some(msaa));
    }
    for samples in [0, 3, 8, 16] {
        assert_eq!(Msaa::from_samples(samples), None, "{samples}");
    }
}

#[test]
fn hdr_formats_know_their_bytes_and_the_features_they_need() {
    assert_eq!(HdrFormat::Rgba16Float.bytes_per_pixel(), 8);
    assert_eq!(HdrFormat::Rg11b10Ufloat.bytes_per_pixel(), 4);
    assert_eq!(HdrFormat::Rgba16Float.required_features(), wgpu::Features::empty());
    assert_eq!(HdrFormat::Rg11b10Ufloat.required_features(), wgpu::Features::RG11B10UFLOAT_RENDERABLE);
}

/// Depth is 4 bytes a pixel; colour adds the HDR format's bytes and 4 for
/// the display colour; MSAA adds, per sample, the HDR bytes and 4 for depth
/// (and nothing for a depth-only view).
#[test]
fn a_views_bytes_are_known_before_it_is_allocated() {
    let (w, h) = (16u32, 8u32);
    let pixels = u64::from(w * h);
    assert_eq!(ViewTargets::bytes_for(w, h, true), pixels * 16);
    assert_eq!(ViewTargets::bytes_for(w, h, false), pixels * 4);
    assert_eq!(ViewTargets::bytes_for_format(w, h, Some(HdrFormat::Rg11b10Ufloat)), pixels * 12);
    assert_eq!(ViewTargets::bytes_for_format(3, 5, None), 60);
    let msaa = |format, samples| ViewTargets::bytes_for_msaa(w, h, format, samples);
    assert_eq!(msaa(Some(HdrFormat::Rgba16Float), 1), pixels * 16);
    assert_eq!(msaa(Some(HdrFormat::Rgba16Float), 2), pixels * (16 + 2 * 12));
    assert_eq!(msaa(Some(HdrFormat::Rg11b10Ufloat), 4), pixels * (12 + 4 * 8));
    assert_eq!(msaa(None, 4), pixels * 4, "depth only: no multisampled colour");
}

/// A page is as square as the tiles need, no larger than its side allows,
/// and a tile may be as large as the side; (columns, rows, pages).
#[test]
fn an_atlas_lays_out_its_tiles_on_as_few_pages_as_fit() {
    assert_eq!(TileAtlas::layout((8, 4), 12, 16), Some((2, 4, 2)));
    assert_eq!(TileAtlas::layout((8, 8), 5, 1024), Some((3, 2, 1)));
    assert_eq!(TileAtlas::layout((16, 4), 1, 16), Some((1, 1, 1)), "a tile as wide as the side");
    assert_eq!(TileAtlas::layout((4, 16), 1, 16), Some((1, 1, 1)), "a tile as tall as the side");
    for (size, tiles) in [((17, 4), 1), ((4, 17), 1), ((0, 4), 1), ((4, 0), 1), ((4, 4), 0)] {
        assert_eq!(TileAtlas::layout(size, tiles, 16), None, "{size:?} × {tiles}");
    }
    let labels = LabelSet::ALL;
    let bytes = TileAtlas::bytes_for((8, 4), (2, 4, 2), Some(8), labels, false);
    assert_eq!(bytes, 16 * 16 * 2 * (8 + 8 + labels.bytes_per_pixel()));
    assert_eq!(TileAtlas::bytes_for((8, 4), (2, 4, 2), None, LabelSet::NONE, false), 16 * 16 * 2 * 8);
}

/// Tiles run row by row across a page, then on to the next page; the
/// atlas's figures are the layout's.
#[test]
fn an_allocated_atlas_places_its_tiles_page_by_page_row_by_row() {
    let gpu = device();
    let labels = LabelSet::ALL;
    let atlas = TileAtlas::new(&gpu.device, (8, 4), 12, Some(HdrFormat::Rgba16Float), labels, false, Some(16), "test")
        .expect("an atlas");
    assert_eq!((atlas.columns, atlas.rows, atlas.pages.len()), (2, 4, 2));
    assert_eq!(atlas.page_size(), (16, 16));
    assert_eq!(atlas.capacity(), 16);
    assert!(atlas.has_hdr());
    assert_eq!(atlas.labels(), labels);
    assert_eq!(atlas.bytes(), TileAtlas::bytes_for((8, 4), (2, 4, 2), Some(8), labels, false));
    let place = |i| atlas.tile(i).map(|t| (t.x, t.y, t.page, t.index));
    assert_eq!(place(0), Some((0, 0, 0, 0)));
    assert_eq!(place(3), Some((8, 4, 0, 3)));
    assert_eq!(place(6), Some((0, 12, 0, 6)));
    assert_eq!(place(9), Some((8, 0, 1, 9)));
    assert_eq!(place(15), Some((8, 12, 1, 15)));
    assert_eq!(place(16), None, "past the capacity");
    let plain = TileAtlas::new(&gpu.device, (8, 4), 2, None, LabelSet::NONE, false, None, "plain").expect("an atlas");
    assert!(!plain.has_hdr());
    assert_eq!(plain.labels(), LabelSet::NONE);
    assert_eq!(plain.bytes(), TileAtlas::bytes_for((8, 4), (2, 1, 1), None, LabelSet::NONE, false));
}

/// Allocated targets count the bytes `bytes_for_msaa` predicted, labels on
/// top; a tile's and an atlas layer's textures are their owners'.
#[test]
fn allocated_targets_count_what_was_predicted() {
    let gpu = device();
    let (w, h) = (16u32, 8u32);
    let pixels = u64::from(w * h);
    let lit = ViewTargets::new(&gpu.device, w, h, "lit");
    assert_eq!(lit.bytes(), ViewTargets::bytes_for(w, h, true));
    assert_eq!(lit.samples(), 1);
    let depth = ViewTargets::depth_only(&gpu.device, w, h, "depth");
    assert_eq!(depth.bytes(), ViewTargets::bytes_for(w, h, false));
    let msaa = ViewTargets::new(&gpu.device, w, h, "msaa").with_msaa(&gpu.device, 4, "msaa");
    assert_eq!(msaa.samples(), 4);
    assert_eq!(msaa.bytes(), ViewTargets::bytes_for_msaa(w, h, Some(HdrFormat::Rgba16Float), 4));
    let single = ViewTargets::new(&gpu.device, w, h, "single").with_msaa(&gpu.device, 1, "single");
    assert_eq!(single.samples(), 1, "one sample is no MSAA");
    let labelled = ViewTargets::new(&gpu.device, w, h, "labels").with_labels(&gpu.device, LabelSet::ALL, "labels");
    assert_eq!(labelled.bytes(), lit.bytes() + pixels * LabelSet::ALL.bytes_per_pixel());
    let unlabelled = ViewTargets::new(&gpu.device, w, h, "none").with_labels(&gpu.device, LabelSet::NONE, "none");
    assert!(unlabelled.labels.is_none());
    let atlas = TileAtlas::new(&gpu.device, (8, 4), 2, None, LabelSet::NONE, false, None, "tiles").expect("an atlas");
    assert_eq!(atlas.view_targets(1).expect("a tile").bytes(), 0);
    let layers = square_array(&gpu, 8, 2, ViewTargets::DEPTH_FORMAT);
    assert_eq!(ViewTargets::atlas_layer(&layers, 1).bytes(), 0);
    // A probe face draws into its cube's layer (the probe's texture) and
    // owns only its depth.
    let cube = square_array(&gpu, 8, 6, ViewTargets::HDR_FORMAT);
    assert_eq!(ViewTargets::probe_face(&gpu.device, &cube, 2, "face").bytes(), 8 * 8 * 4);
}

/// Targets fit a request when they are its size, own their textures, have
/// colour exactly when it asks for colour, and its samples.
#[test]
fn targets_fit_only_the_request_they_were_made_for() {
    let gpu = device();
    let (w, h) = (16u32, 8u32);
    let lit = ViewTargets::new(&gpu.device, w, h, "lit");
    assert!(lit.fits(w, h, true, 1));
    assert!(!lit.fits(w + 1, h, true, 1));
    assert!(!lit.fits(w, h + 1, true, 1));
    assert!(!lit.fits(w, h, false, 1), "colour where none is asked for");
    assert!(!lit.fits(w, h, true, 4));
    let depth = ViewTargets::depth_only(&gpu.device, w, h, "depth");
    assert!(depth.fits(w, h, false, 1));
    assert!(!depth.fits(w, h, true, 1), "no colour where colour is asked for");
    let msaa = ViewTargets::new(&gpu.device, w, h, "msaa").with_msaa(&gpu.device, 4, "msaa");
    assert!(msaa.fits(w, h, true, 4));
    let layers = square_array(&gpu, w, 2, ViewTargets::DEPTH_FORMAT);
    assert!(!ViewTargets::atlas_layer(&layers, 0).fits(w, w, false, 1), "an atlas layer owns no texture");
}

/// Label targets hold one plane for each label of their set, of its format
/// and the view's size, and count the bytes of those planes only.
#[test]
fn label_targets_hold_a_plane_for_each_label_of_their_set() {
    let gpu = device();
    let set = LabelSet::of(&[Label::Normal, Label::LinearDepth]);
    let targets = LabelTargets::new(&gpu.device, 4, 2, set, "view 0");
    assert_eq!(targets.set(), set);
    assert_eq!(targets.bytes_per_pixel(), 12);
    for label in Label::ALL {
        let plane = targets.plane(label);
        assert_eq!(plane.is_some(), set.contains(label), "{label:?}");
        if let Some(plane) = plane {
            assert_eq!(plane.texture.format(), label.format(), "{label:?}");
            assert_eq!((plane.texture.width(), plane.texture.height()), (4, 2), "{label:?}");
        }
    }
    let none = LabelTargets::new(&gpu.device, 4, 2, LabelSet::NONE, "view 1");
    assert!(none.set().is_empty());
    assert_eq!(none.bytes_per_pixel(), 0);
}
