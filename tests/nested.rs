//! Materials made of others: `twosided` (a material per side) against renders
//! of its materials alone and against analytic values, and the scene's checks
//! of what such materials name.

mod common;

use pathmix::scene::Scene;

/// A plane seen from above (`above`) or below under a uniform sky of 1, with
/// the materials `[materials.*]` of `materials` and the plane's `material`:
/// a Lambertian side of albedo a shows exactly a (one bounce to the sky).
fn plane_under_sky(materials: &str, material: &str, above: bool) -> Scene {
    let y = if above { 1 } else { -1 };
    common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, {y}, 0]
        lookat = [0, 0, 0]
        vup = [0, 0, -1]
        vfov = 20
        width = 8
        height = 8
        [render]
        spp = 256
        max_depth = 4
        strategy = "bsdf"
        sampler = "independent"
        background = [1, 1, 1]
        {materials}
        [[objects]]
        type = "quad"
        q = [-1000, 0, -1000]
        u = [0, 0, 2000]
        v = [2000, 0, 0]
        material = "{material}"
        "#
    ))
}

/// Two one-sided Lambertian materials, `top` (0.3) and `under` (0.7), and
/// `leaf`, `top` on the front (the plane's normal is +y) and `under` on the back.
const SIDES: &str = r#"
    [materials.top]
    type = "lambertian"
    albedo = [0.3, 0.3, 0.3]
    one_sided = true
    [materials.under]
    type = "lambertian"
    albedo = [0.7, 0.7, 0.7]
    one_sided = true
    [materials.leaf]
    type = "twosided"
    front = "top"
    back = "under"
"#;

/// Seen from the front, a twosided plane renders as its front material alone,
/// from the back as its back material alone (which sees the flipped frame as
/// its front: one-sided, it would be black there on its own), bit for bit:
/// picking a side draws no random number.
#[test]
fn each_side_of_a_twosided_plane_is_its_material_alone() {
    let ctx = gpu_or_skip!();
    let render = |scene: &Scene| common::render(ctx, scene, &common::with_variance());
    for (above, alone, albedo) in [(true, "top", 0.3), (false, "under", 0.7)] {
        let both = render(&plane_under_sky(SIDES, "leaf", above));
        common::assert_every_pixel_is(&both, albedo, 1e-6, alone);
        // The material alone, on the side it faces.
        let single = render(&plane_under_sky(SIDES, alone, true));
        assert_eq!(both.mean().pixels, single.mean().pixels, "{alone}");
    }
    // A one-sided material seen from behind is black: the back material does
    // not see the hit as its back.
    let behind = render(&plane_under_sky(SIDES, "under", false));
    common::assert_every_pixel_is(&behind, 0.0, 0.0, "under from behind");
}

/// A patch of a floor (the y = 0 plane) seen straight down from 0.5, lit by a
/// disk light of radius r and radiance L at height h facing down, under every
/// strategy, direct light only: the floor's `floor` material, of
/// `materials`, reflects a L r^2 / (r^2 + h^2) for a Lambertian albedo a.
/// `down`: the floor's normal points down (the light and camera see its back).
/// Asserts the patch's mean is `expected` within 4 standard errors (plus 1e-4
/// relative).
fn assert_lit_floor(materials: &str, down: bool, expected: f64, what: &str) {
    for strategy in STRATEGIES {
        let Some((mean, error)) = lit_floor(materials, "floor", down, strategy) else {
            return;
        };
        println!("{what} {strategy}: {mean:.6} ± {error:.6}, expected {expected:.6}");
        assert!(
            (mean - expected).abs() < 4.0 * error + 1e-4 * expected,
            "{what} {strategy}: {mean} ± {error} against {expected}"
        );
    }
}

const STRATEGIES: [&str; 4] = ["bsdf", "light", "mixture", "nee-mis"];

/// `assert_lit_floor`'s patch under `strategy`, the floor of material `floor`:
/// its mean and standard error (`None` without a device).
fn lit_floor(materials: &str, floor: &str, down: bool, strategy: &str) -> Option<(f64, f64)> {
    let ctx = common::gpu()?;
    let (u, v) = match down {
        false => ("[0, 0, 20]", "[20, 0, 0]"),
        true => ("[20, 0, 0]", "[0, 0, 20]"),
    };
    {
        let scene = common::scene_text(&format!(
            r#"
            [camera]
            lookfrom = [0, 0.5, 0]
            lookat = [0, 0, 0]
            vup = [0, 0, -1]
            vfov = 0.2
            width = 4
            height = 4
            [render]
            spp = 4096
            max_depth = 1
            strategy = "{strategy}"
            sampler = "independent"
            {materials}
            [materials.lamp]
            type = "light"
            emit = [4, 4, 4]
            [[objects]]
            type = "quad"
            q = [-10, 0, -10]
            u = {u}
            v = {v}
            material = "{floor}"
            [[objects]]
            type = "disk"
            center = [0, 2, 0]
            u = [0.5, 0, 0]
            v = [0, 0, 0.5]
            material = "lamp"
            "#
        ));
        let acc = common::render(ctx, &scene, &common::with_variance());
        Some(common::image_mean_and_error(&acc))
    }
}

/// The floor patch under a disk light: a twosided floor lit on its back
/// reflects by its back material under every strategy (light sampling and MIS
/// evaluate the material the side picked), and on its front by its front one.
#[test]
fn every_strategy_lights_the_side_hit_by_its_material() {
    let direct = |albedo: f64| albedo * 4.0 * 0.25 / (0.25 + 4.0);
    let floor = format!(
        "{SIDES}\n[materials.floor]\ntype = \"twosided\"\nfront = \"top\"\nback = \"under\""
    );
    assert_lit_floor(&floor, false, direct(0.3), "front");
    assert_lit_floor(&floor, true, direct(0.7), "back");
}

/// What a material made of others names is checked with the scene: the
/// materials exist, neither emit nor are masked, and nest at most
/// `MATERIAL_NESTING` deep with no cycle, each refused at its key.
#[test]
fn nested_materials_are_checked_where_they_are_named() {
    let error = |materials: &str| {
        let text = format!(
            r#"
            [camera]
            lookfrom = [0, 1, 0]
            lookat = [0, 0, 0]
            vup = [0, 0, -1]
            [materials.a]
            type = "lambertian"
            albedo = [0.5, 0.5, 0.5]
            {materials}
            "#
        );
        Scene::parse(&text, "test.toml").unwrap_err().to_string()
    };
    let e = error("[materials.t]\ntype = \"twosided\"\nfront = \"a\"\nback = \"b\"");
    assert!(
        e.contains("test.toml: materials.t.back: unknown material `b`"),
        "{e}"
    );
    // An unknown name below another nested material (was a panic: the depth
    // walk followed it before it was checked).
    let e = error(
        "[materials.s]\ntype = \"twosided\"\nfront = \"t\"\nback = \"a\"\n\
         [materials.t]\ntype = \"twosided\"\nfront = \"x\"\nback = \"a\"",
    );
    assert!(e.contains("materials.t.front: unknown material `x`"), "{e}");
    let e = error(
        "[materials.lamp]\ntype = \"light\"\nemit = [1, 1, 1]\n\
         [materials.t]\ntype = \"twosided\"\nfront = \"lamp\"\nback = \"a\"",
    );
    assert!(
        e.contains("materials.t.front: material `lamp` emits inside a twosided material"),
        "{e}"
    );
    let e = error(
        "[materials.m]\ntype = \"lambertian\"\nalbedo = [1, 1, 1]\nopacity = 0.5\n\
         [materials.t]\ntype = \"twosided\"\nfront = \"a\"\nback = \"m\"",
    );
    assert!(
        e.contains("materials.t.back: material `m` is masked"),
        "{e}"
    );
    let e = error(
        "[materials.t]\ntype = \"twosided\"\nfront = \"a\"\nback = \"u\"\n\
         [materials.u]\ntype = \"twosided\"\nfront = \"t\"\nback = \"a\"",
    );
    assert!(
        e.contains("materials.t: its materials make a cycle: `t` -> `u` -> `t`"),
        "{e}"
    );
    // Five deep: t1 -> t2 -> ... -> t5 -> a.
    let chain: String = (1..=5)
        .map(|i| {
            let next = if i == 5 {
                "a".to_string()
            } else {
                format!("t{}", i + 1)
            };
            format!("[materials.t{i}]\ntype = \"twosided\"\nfront = \"{next}\"\nback = \"a\"\n")
        })
        .collect();
    let e = error(&chain);
    assert!(
        e.contains("materials.t1: its materials nest 5 deep (`t1` -> `t2` -> `t3` -> `t4` -> `t5` -> `a`), deeper than the 4"),
        "{e}"
    );
}

/// Two-sided Lambertian materials `dull` (0.3) and `pale` (0.7), a rough
/// conductor `shiny`, and `[materials.mix]`, a blend of `first` and `second`
/// with `weight` (a TOML value).
fn blend(weight: &str, first: &str, second: &str) -> String {
    format!(
        r#"
        [materials.dull]
        type = "lambertian"
        albedo = [0.3, 0.3, 0.3]
        [materials.pale]
        type = "lambertian"
        albedo = [0.7, 0.7, 0.7]
        [materials.shiny]
        type = "roughconductor"
        alpha = 0.3
        [materials.mix]
        type = "blend"
        weight = {weight}
        first = "{first}"
        second = "{second}"
        "#
    )
}

/// A blend of weight 0 is its first material, of weight 1 its second, every
/// sample of it (the plane under the sky: exactly the albedo picked).
#[test]
fn a_blend_of_weight_0_or_1_is_one_of_its_materials() {
    let ctx = gpu_or_skip!();
    for (weight, albedo) in [("0", 0.3), ("1", 0.7)] {
        let scene = plane_under_sky(&blend(weight, "dull", "pale"), "mix", true);
        let acc = common::render(ctx, &scene, &common::with_variance());
        common::assert_every_pixel_is(&acc, albedo, 1e-6, &format!("weight {weight}"));
    }
}

/// A blend of weight w renders as (1 - w) A + w B of its two materials
/// rendered apart: the floor patch under the disk light, a Lambertian and a
/// rough conductor blended at 0.25, under every strategy (the light sample's
/// MIS against the material picked), within 4 standard errors of the
/// difference (the three renders' errors combined).
#[test]
fn a_blend_renders_as_the_blend_of_its_materials_rendered_apart() {
    let w = 0.25;
    for strategy in STRATEGIES {
        let materials = blend(&w.to_string(), "dull", "shiny");
        let floor = |material: &str| lit_floor(&materials, material, false, strategy);
        let (Some(a), Some(b), Some(mixed)) = (floor("dull"), floor("shiny"), floor("mix")) else {
            return;
        };
        let expected = (1.0 - w) * a.0 + w * b.0;
        let error = (mixed.1.powi(2) + ((1.0 - w) * a.1).powi(2) + (w * b.1).powi(2)).sqrt();
        println!(
            "blend {strategy}: {:.6} ± {:.6}, expected {expected:.6} (A {:.6}, B {:.6})",
            mixed.0, mixed.1, a.0, b.0
        );
        assert!(
            (mixed.0 - expected).abs() < 4.0 * error,
            "{strategy}: {} against {expected} ± {error}",
            mixed.0
        );
        // Far enough apart for the test to tell a blend from either alone.
        assert!((a.0 - b.0).abs() > 20.0 * error, "{a:?} {b:?}");
    }
}

/// A checkerboard weight of 0 and 1 gives the first material on its squares
/// of 0 and the second on those of 1: a plane under the sky whose view the
/// checkerboard's four squares split into four 4x4 quadrants, each pixel
/// exactly one of the two albedos, the quadrants alternating.
#[test]
fn a_textured_weight_picks_a_material_per_checker_square() {
    let ctx = gpu_or_skip!();
    let weight = "{ type = \"checkerboard\", color0 = [0, 0, 0], color1 = [1, 1, 1] }";
    let scene = common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, 0.5, 0]
        lookat = [0, 0, 0]
        vup = [0, 0, -1]
        vfov = 20
        width = 8
        height = 8
        filter = "box"
        [render]
        spp = 64
        max_depth = 4
        strategy = "bsdf"
        sampler = "independent"
        background = [1, 1, 1]
        {}
        [[objects]]
        type = "quad"
        q = [-0.1, 0, -0.1]
        u = [0, 0, 0.2]
        v = [0.2, 0, 0]
        material = "mix"
        "#,
        blend(weight, "dull", "pale")
    ));
    let acc = common::render(ctx, &scene, &common::with_variance());
    let image = acc.mean();
    let at = |x: usize, y: usize| image.pixels[y * 8 + x][0];
    for y in 0..8 {
        for x in 0..8 {
            let diagonal = (x < 4) == (y < 4);
            let expected = if diagonal { at(0, 0) } else { at(7, 0) };
            assert!(
                (at(x, y) - expected).abs() <= 1e-6,
                "({x}, {y}): {} != {expected}",
                at(x, y)
            );
        }
    }
    let mut corners = [at(0, 0), at(7, 0)];
    corners.sort_by(f32::total_cmp);
    assert!(
        (corners[0] - 0.3).abs() < 1e-6 && (corners[1] - 0.7).abs() < 1e-6,
        "{corners:?}"
    );
}
