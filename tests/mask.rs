//! Masked surfaces (`opacity`, Mitsuba's `mask`): a surface there with
//! probability `opacity`, which rays pass through otherwise and shadow rays by
//! the transmittance, against analytic values.

mod common;

use pathmix::render::RenderOptions;
use pathmix::scene::Scene;
use std::f64::consts::PI;

/// A plane of albedo `a`, seen from above under a uniform sky of 1 with nothing
/// below it, at opacity `o`: a camera ray passes through it to the sky (1) with
/// probability `1 - o`, else finds it and reflects `a` of the sky. So
/// `(1 - o) + o a`; at 0 every sample is 1 (the plane is invisible), at 1 the
/// image is the unmasked plane's, bit for bit (no random number is drawn for an
/// opaque surface, though the kernel has the mask's code for the quad far
/// below that no ray reaches).
#[test]
fn a_masked_plane_is_seen_in_proportion_to_its_opacity() {
    let ctx = gpu_or_skip!();
    let albedo = 0.5;
    let plane = |opacity: Option<f64>| {
        let opacity = opacity.map_or(String::new(), |o| format!("opacity = {o}"));
        common::scene_text(&format!(
            r#"
            [camera]
            lookfrom = [0, 1, 0]
            lookat = [0, 0, 0]
            vup = [0, 0, -1]
            vfov = 20
            width = 8
            height = 8
            [render]
            spp = 1024
            max_depth = 4
            strategy = "bsdf"
            sampler = "independent"
            background = [1, 1, 1]
            [materials.plane]
            type = "lambertian"
            albedo = [{albedo}, {albedo}, {albedo}]
            {opacity}
            [materials.hidden]
            type = "lambertian"
            albedo = [0.5, 0.5, 0.5]
            opacity = 0.5
            [[objects]]
            type = "quad"
            q = [-1000, 0, -1000]
            u = [0, 0, 2000]
            v = [2000, 0, 0]
            material = "plane"
            [[objects]]
            type = "quad"
            q = [500, -100, 500]
            u = [0, 0, 2]
            v = [2, 0, 0]
            material = "hidden"
            "#
        ))
    };
    let render = |scene: &Scene| common::render(ctx, scene, &common::with_variance());
    // Invisible: exactly the sky.
    let invisible = render(&plane(Some(0.0)));
    common::assert_every_pixel_is(&invisible, 1.0, 0.0, "opacity 0");
    // Opaque: the unmasked plane's image, though this kernel has the mask's code.
    let opaque = render(&plane(Some(1.0)));
    let unmasked = render(&plane(None));
    assert_eq!(opaque.mean().pixels, unmasked.mean().pixels, "opacity 1");
    common::assert_every_pixel_is(&opaque, albedo as f32, 1e-6, "opacity 1");
    // Half: the mean of the two, within 4 standard errors.
    let (mean, error) = common::image_mean_and_error(&render(&plane(Some(0.5))));
    let expected = 0.5 * 1.0 + 0.5 * albedo;
    println!("opacity 0.5: {mean:.5} ± {error:.5}, expected {expected}");
    assert!(
        (mean - expected).abs() < 4.0 * error,
        "{mean} ± {error} against {expected}"
    );
}

/// An opacity that is a texture (`opacity = { type = ..., ... }`): its
/// luminance at the hit, drawn against as a constant's. The plane of
/// `a_masked_plane_is_seen_in_proportion_to_its_opacity` with a checkerboard
/// of one value for its opacity renders as that constant does: 0, every sample
/// the sky; 1, every sample the plane; 1/2, their mean within noise. Then a
/// checkerboard of 0 and 1 whose cells are the pixels (the plane exactly fills
/// the view, 8 cells across): each pixel is the sky or the plane alone, half of
/// them each, which a texture read anywhere but at the hit (or by its mean)
/// cannot give.
#[test]
fn a_textured_opacity_is_read_where_the_ray_hits() {
    let ctx = gpu_or_skip!();
    let albedo = 0.5;
    // The half-width of the view at the plane: the camera is 1 above it, vfov 20.
    let h = 10f64.to_radians().tan();
    let plane = |opacity: &str| {
        common::scene_text(&format!(
            r#"
            [camera]
            lookfrom = [0, 1, 0]
            lookat = [0, 0, 0]
            vup = [0, 0, -1]
            vfov = 20
            width = 8
            height = 8
            [render]
            spp = 1024
            max_depth = 4
            strategy = "bsdf"
            sampler = "independent"
            background = [1, 1, 1]
            [materials.plane]
            type = "lambertian"
            albedo = [{albedo}, {albedo}, {albedo}]
            opacity = {opacity}
            [[objects]]
            type = "quad"
            q = [{m}, 0, {m}]
            u = [0, 0, {w}]
            v = [{w}, 0, 0]
            material = "plane"
            "#,
            m = -h,
            w = 2.0 * h,
        ))
    };
    let constant = |o: f64| format!("{{ type = \"checkerboard\", color0 = {o}, color1 = {o} }}");
    let render = |scene: &Scene| common::render(ctx, scene, &common::with_variance());
    common::assert_every_pixel_is(&render(&plane(&constant(0.0))), 1.0, 0.0, "texture 0");
    common::assert_every_pixel_is(
        &render(&plane(&constant(1.0))),
        albedo as f32,
        1e-6,
        "texture 1",
    );
    let expected = 0.5 * 1.0 + 0.5 * albedo;
    for opacity in [constant(0.5), "0.5".to_string()] {
        let (mean, error) = common::image_mean_and_error(&render(&plane(&opacity)));
        println!("opacity {opacity}: {mean:.5} ± {error:.5}, expected {expected}");
        assert!(
            (mean - expected).abs() < 4.0 * error,
            "{opacity}: {mean} ± {error} against {expected}"
        );
    }
    let cells = "{ type = \"checkerboard\", color0 = 0, color1 = 1, to_uv = { scale = 4 } }";
    let image = render(&plane(cells)).mean();
    let (mut sky, mut seen) = (0, 0);
    for pixel in &image.pixels {
        // A ray near a pixel's edge may round into the next cell: 1%.
        if pixel.iter().all(|&c| (c - 1.0).abs() < 0.01) {
            sky += 1;
        } else if pixel.iter().all(|&c| (c - albedo as f32).abs() < 0.01) {
            seen += 1;
        } else {
            panic!("a pixel neither the sky nor the plane: {pixel:?}");
        }
    }
    assert_eq!((sky, seen), (32, 32));
}

/// Renders the floor patch of `common::assert_lit_floor`'s scene (albedo
/// `albedo`, straight below `lights`) with `extra` objects and materials added,
/// under every strategy, direct light only (`max_depth` 1): a BSDF sample that
/// passes a masked occluder (a null event, no bounce) still reaches the light.
/// Asserts the patch's mean is `expected` within 4 standard errors (plus 1e-4
/// relative, and 1e-6 absolute for an expected 0).
fn assert_floor(albedo: f64, lights: &str, extra: &str, expected: f64, what: &str) {
    let ctx = gpu_or_skip!();
    common::assert_floor_patch(
        ctx,
        (albedo, 0.5),
        &format!("{lights}\n{extra}"),
        (expected, 1e-6),
        what,
    );
}

/// A disk light of radius r and radiance L at height h, facing down (its
/// normal is u x v), or up: the floor straight below reflects
/// a L r^2 / (r^2 + h^2).
fn disk_light(r: f64, h: f64, emit: f64, opacity: f64, up: bool) -> String {
    let (u, v) = match up {
        false => (format!("[{r}, 0, 0]"), format!("[0, 0, {r}]")),
        true => (format!("[0, 0, {r}]"), format!("[{r}, 0, 0]")),
    };
    format!(
        r#"
        [materials.lamp]
        type = "light"
        emit = [{emit}, {emit}, {emit}]
        opacity = {opacity}
        [[objects]]
        type = "disk"
        center = [0, {h}, 0]
        u = {u}
        v = {v}
        material = "lamp"
        "#
    )
}

/// A masked occluder (a grey plane between the floor and the light, its top
/// away from the light's reach from below) lets `1 - opacity` of the light
/// through: the floor's radiance is `1 - opacity` of the unoccluded one,
/// under every strategy (under `nee-mis` the shadow ray's transmittance and the
/// BSDF sample's null events weighed against each other by MIS). For an area
/// light and for a point light (its shadow ray's transmittance alone); with a
/// constant opacity and with a texture of the same value.
#[test]
fn a_masked_occluder_lets_its_transparency_of_the_light_through() {
    let (r, h, emit, albedo) = (0.5f64, 2.0f64, 4.0f64, 0.6f64);
    let area = albedo * emit * r * r / (r * r + h * h);
    let intensity = 3.0;
    let point = albedo / PI * intensity / (h * h);
    let point_light =
        format!("[[lights]]\ntype = \"point\"\nposition = [0, {h}, 0]\nintensity = {intensity}\n");
    // A constant opacity, and a texture of that value (evaluated where the
    // shadow ray or the path passes the occluder).
    let opacities = [0.0, 0.5, 1.0].into_iter().flat_map(|o| {
        [
            (o, format!("{o}")),
            (
                o,
                format!("{{ type = \"checkerboard\", color0 = {o}, color1 = {o} }}"),
            ),
        ]
    });
    for (opacity, value) in opacities {
        let occluder = format!(
            r#"
            [materials.occluder]
            type = "lambertian"
            albedo = [0.5, 0.5, 0.5]
            opacity = {value}
            [[objects]]
            type = "quad"
            q = [-5, 1, -5]
            u = [0, 0, 10]
            v = [10, 0, 0]
            material = "occluder"
            "#
        );
        let what = format!("opacity {value}");
        let expected = (1.0 - opacity) * area;
        assert_floor(
            albedo,
            &disk_light(r, h, emit, 1.0, false),
            &occluder,
            expected,
            &what,
        );
        let expected = (1.0 - opacity) * point;
        assert_floor(
            albedo,
            &point_light,
            &occluder,
            expected,
            &format!("{what}, point"),
        );
    }
}

/// An emitting masked surface emits as it would unmasked (Mitsuba's emitters
/// belong to the shape) and is sampled as before: a masked disk light gives
/// the floor the unmasked disk's irradiance under every strategy, its light
/// density and the BSDF samples that find it agreeing. Seen head-on against a
/// sky of 1, it shows its radiance plus `1 - opacity` of the sky behind it.
#[test]
fn an_emitting_masked_surface_keeps_its_light_density() {
    let (r, h, emit, albedo) = (0.5f64, 2.0f64, 4.0f64, 0.6f64);
    let expected = albedo * emit * r * r / (r * r + h * h);
    assert_floor(
        albedo,
        &disk_light(r, h, emit, 0.5, false),
        "",
        expected,
        "masked lamp",
    );

    let ctx = gpu_or_skip!();
    let opacity = 0.25;
    let scene = common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, 1, 0]
        lookat = [0, 0, 0]
        vup = [0, 0, -1]
        vfov = 20
        width = 8
        height = 8
        [render]
        spp = 1024
        max_depth = 2
        strategy = "nee-mis"
        sampler = "independent"
        background = [1, 1, 1]
        {}
        "#,
        disk_light(1000.0, 0.0, emit, opacity, true)
    ));
    let acc = common::render(ctx, &scene, &common::with_variance());
    let (mean, error) = common::image_mean_and_error(&acc);
    let expected = emit + (1.0 - opacity);
    println!("masked lamp head-on: {mean:.5} ± {error:.5}, expected {expected}");
    assert!(
        (mean - expected).abs() < 4.0 * error,
        "{mean} ± {error} against {expected}"
    );
}

/// The loop budget counts a masked scene's shadow-ray walks: every invocation
/// finishes its samples (no truncation, which `common::render` asserts) in a
/// stack of masked planes deeper than a shadow ray's walk, over a floor lit by
/// a light behind them all, under `nee-mis` at a high `max_depth`.
#[test]
fn a_stack_of_masks_stays_within_the_loop_budget() {
    let ctx = gpu_or_skip!();
    let planes: String = (1..=12)
        .map(|i| {
            format!(
                "[[objects]]\ntype = \"quad\"\nq = [-5, {y}, -5]\nu = [0, 0, 10]\nv = [10, 0, 0]\n\
                 material = \"leaf\"\n",
                y = 0.1 * i as f64
            )
        })
        .collect();
    let scene = common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, 3, 0]
        lookat = [0, 0, 0]
        vup = [0, 0, -1]
        vfov = 30
        width = 8
        height = 8
        [render]
        spp = 64
        max_depth = 32
        strategy = "nee-mis"
        [materials.floor]
        type = "lambertian"
        albedo = [0.5, 0.5, 0.5]
        [materials.leaf]
        type = "lambertian"
        albedo = [0.5, 0.5, 0.5]
        opacity = 0.1
        [[objects]]
        type = "quad"
        q = [-10, 0, -10]
        u = [0, 0, 20]
        v = [20, 0, 0]
        material = "floor"
        {planes}
        {}
        "#,
        disk_light(0.5, 2.0, 4.0, 1.0, false)
    ));
    common::render(ctx, &scene, &RenderOptions::default());
}

/// A textured opacity whose image is missing, or is no image, is refused with
/// exit code 2 and nothing written, naming the scene file, the field and the
/// image (in a Mitsuba scene: the file, the line of the element and the image).
#[test]
fn a_bad_opacity_image_is_refused_naming_file_field_and_image() {
    let dir = common::TempDir::new("mask", "bad-opacity");
    std::fs::write(dir.join("leaf.png"), "not an image").unwrap();
    let toml = |file: &str| {
        format!(
            r#"
[camera]
lookfrom = [0, 1, 0]
lookat = [0, 0, 0]
vup = [0, 0, -1]
[materials.leaf]
type = "lambertian"
albedo = [0.5, 0.5, 0.5]
opacity = {{ type = "bitmap", file = "{file}" }}
[[objects]]
type = "quad"
q = [-1, 0, -1]
u = [0, 0, 2]
v = [2, 0, 0]
material = "leaf"
"#
        )
    };
    let xml = |file: &str| {
        format!(
            r#"<scene version="3.0.0">
<shape type="rectangle">
<bsdf type="mask">
<texture name="opacity" type="bitmap"><string name="filename" value="{file}"/></texture>
<bsdf type="diffuse"/>
</bsdf>
</shape>
<sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
</scene>
"#
        )
    };
    let cases = [
        (
            "missing.toml",
            toml("missing.png"),
            vec!["missing.toml", "materials.leaf.opacity.file", "missing.png"],
        ),
        (
            "garbage.toml",
            toml("leaf.png"),
            vec!["garbage.toml", "materials.leaf.opacity.file", "leaf.png"],
        ),
        (
            "missing.xml",
            xml("missing.png"),
            vec!["missing.xml:4:", "missing.png"],
        ),
        (
            "garbage.xml",
            xml("leaf.png"),
            vec!["garbage.xml:", "opacity", "leaf.png"],
        ),
    ];
    for (name, text, fragments) in cases {
        let scene = dir.join(name);
        std::fs::write(&scene, text).unwrap();
        let out = dir.join("out.png");
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_pathmix"))
            .args([
                "render",
                scene.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let message = String::from_utf8_lossy(&output.stderr);
        println!("{name}: {message}");
        assert_eq!(output.status.code(), Some(2), "{name}: {message}");
        for fragment in fragments {
            assert!(
                message.contains(fragment),
                "{name}: lacks {fragment:?}: {message}"
            );
        }
        assert!(!out.exists(), "{name}: an image was written");
    }
}
