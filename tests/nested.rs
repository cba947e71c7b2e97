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
