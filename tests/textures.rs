//! Textures on material colours: where a texture lands (each shape's texture
//! coordinates), what it multiplies, how bitmaps are filtered, wrapped and
//! decoded, and the bad inputs refused.
//!
//! Most renders here are one bounce off a Lambertian surface under a uniform
//! background of 1 with the `bsdf` strategy: each sample is then exactly the
//! albedo where its camera ray hits (the cosine-sampled bounce escapes: every
//! surface is flat or convex), so a pixel whose whole footprint shows one
//! texel is that texel's colour to rounding.

mod common;

use glam::{DVec3, Vec2, Vec3};
use pathmix::kernel::SceneStorage;
use pathmix::pack::CameraFrame;
use pathmix::render::RenderOptions;
use pathmix::scene::Scene;
use std::path::Path;

/// A 4 x 4 map whose texels all differ: a texel in the wrong place shows.
fn distinct(x: usize, y: usize) -> [f32; 3] {
    [
        (x + 1) as f32 / 5.0,
        (y + 1) as f32 / 5.0,
        ((x + 2 * y) % 3 + 1) as f32 / 4.0,
    ]
}

/// The scene `body` seen from `lookfrom` toward `lookat` (`size`² pixels,
/// vfov 40), one bounce under a background of 1, written into `dir` next to
/// its images.
fn scene(
    dir: &Path,
    body: &str,
    view: ([f32; 3], [f32; 3], [f32; 3]),
    size: u32,
    spp: u32,
) -> Scene {
    let (lookfrom, lookat, vup) = view;
    let text = format!(
        "[camera]\nlookfrom = {lookfrom:?}\nlookat = {lookat:?}\nvup = {vup:?}\nvfov = 40\nwidth = {size}\nheight = {size}\n\
         [render]\nspp = {spp}\nmax_depth = 1\nstrategy = \"bsdf\"\nbackground = [1, 1, 1]\n{body}"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap()
}

/// Texture coordinates of a shape where a ray meets it (Mitsuba 3's
/// conventions, transcribed in f64), or `None` where it misses.
type Shape = dyn Fn(DVec3, DVec3) -> Option<Vec2>;

fn quad_uv(q: DVec3, u: DVec3, v: DVec3) -> impl Fn(DVec3, DVec3) -> Option<Vec2> {
    move |o, d| {
        let n = u.cross(v);
        let t = (q - o).dot(n) / d.dot(n);
        let p = o + t * d - q;
        let w = n / n.dot(n);
        let (a, b) = (w.dot(p.cross(v)), w.dot(u.cross(p)));
        (t > 0.0 && (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b))
            .then(|| Vec2::new(a as f32, b as f32))
    }
}

fn disk_uv(c: DVec3, u: DVec3, v: DVec3) -> impl Fn(DVec3, DVec3) -> Option<Vec2> {
    move |o, d| {
        let n = u.cross(v);
        let t = (c - o).dot(n) / d.dot(n);
        let p = o + t * d - c;
        let w = n / n.dot(n);
        let (a, b) = (w.dot(p.cross(v)), w.dot(u.cross(p)));
        let r = (a * a + b * b).sqrt();
        let phi = b.atan2(a).rem_euclid(std::f64::consts::TAU);
        (t > 0.0 && r <= 1.0).then(|| Vec2::new(r as f32, (phi / std::f64::consts::TAU) as f32))
    }
}

fn sphere_uv(c: DVec3, r: f64) -> impl Fn(DVec3, DVec3) -> Option<Vec2> {
    move |o, d| {
        let oc = o - c;
        let b = oc.dot(d);
        let disc = b * b - oc.dot(oc) + r * r;
        if disc < 0.0 {
            return None;
        }
        let t = -b - disc.sqrt();
        let local = (o + t * d - c) / r;
        let phi = local.y.atan2(local.x).rem_euclid(std::f64::consts::TAU);
        let theta = local.z.clamp(-1.0, 1.0).acos();
        (t > 0.0).then(|| {
            Vec2::new(
                (phi / std::f64::consts::TAU) as f32,
                (theta / std::f64::consts::PI) as f32,
            )
        })
    }
}

/// A triangle's uv: the vertex uvs interpolated (barycentric).
fn triangle_uv(p: [DVec3; 3], uv: [Vec2; 3]) -> impl Fn(DVec3, DVec3) -> Option<Vec2> {
    move |o, d| {
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let t = (p[0] - o).dot(n) / d.dot(n);
        let x = o + t * d;
        let area = |a: DVec3, b: DVec3| (a - x).cross(b - x).dot(n) / n.dot(n);
        let (b0, b1, b2) = (area(p[1], p[2]), area(p[2], p[0]), area(p[0], p[1]));
        (t > 0.0 && b0 >= 0.0 && b1 >= 0.0 && b2 >= 0.0)
            .then(|| b0 as f32 * uv[0] + b1 as f32 * uv[1] + b2 as f32 * uv[2])
    }
}

/// The camera ray through film point (x, y) (pixel units from the top-left
/// corner of the image), as the kernel builds it.
fn camera_ray(scene: &Scene, x: f64, y: f64) -> (DVec3, DVec3) {
    let f = CameraFrame::new(&scene.camera);
    let d = f.to_pixel00.as_dvec3()
        + (x - 0.5) * f.delta_u.as_dvec3()
        + (y - 0.5) * f.delta_v.as_dvec3();
    (f.origin.as_dvec3(), d.normalize())
}

/// The texture's value at an `n` x `n` grid of points over pixel (x, y), or
/// `None` where some ray misses the shape.
fn footprint(
    scene: &Scene,
    shape: &Shape,
    lookup: &dyn Fn(Vec2) -> Vec3,
    x: u32,
    y: u32,
    n: u32,
) -> Option<Vec<Vec3>> {
    let mut values = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let (o, d) = camera_ray(
                scene,
                x as f64 + i as f64 / n as f64,
                y as f64 + j as f64 / n as f64,
            );
            values.push(lookup(shape(o, d)?));
        }
    }
    Some(values)
}

fn the_texture(scene: &Scene) -> &pathmix::scene::Texture {
    scene.materials[0]
        .texture
        .as_ref()
        .expect("a textured material")
}

/// Renders with the scene baked, in buffers, through the BVH and with the
/// general kernel, and checks every pixel whose footprint shows one colour of
/// the texture: exactly that colour. Returns how many pixels were checked.
fn assert_uniform_pixels_exact(scene: &Scene, shape: &Shape, what: &str) -> usize {
    let ctx = common::gpu().expect("a device");
    let texture = the_texture(scene);
    let lookup = |uv: Vec2| texture.eval(uv);
    let storage = |s| RenderOptions {
        scene_storage: Some(s),
        ..RenderOptions::default()
    };
    let general = RenderOptions {
        general_kernel: true,
        ..RenderOptions::default()
    };
    let means: Vec<_> = [
        storage(SceneStorage::Baked),
        storage(SceneStorage::Buffers),
        storage(SceneStorage::Bvh),
        general,
    ]
    .iter()
    .map(|options| common::render(ctx, scene, options).mean())
    .collect();
    let width = scene.camera.width;
    let mut checked = 0;
    for y in 0..scene.camera.height {
        for x in 0..width {
            let Some(values) = footprint(scene, shape, &lookup, x, y, 4) else {
                continue;
            };
            if values.iter().any(|v| *v != values[0]) {
                continue;
            }
            for (k, mean) in means.iter().enumerate() {
                let got = Vec3::from(mean.pixels[(y * width + x) as usize]);
                assert!(
                    (got - values[0]).abs().max_element() <= 1e-6,
                    "{what} (render {k}): pixel ({x}, {y}) is {got}, the texel there {}",
                    values[0]
                );
            }
            checked += 1;
        }
    }
    checked
}

/// Each shape's texture coordinates put each texel of a 4 x 4 map (nearest,
/// every texel a different colour) where Mitsuba's parameterisation says:
/// quads (a, b), disks polar (r, phi / 2 pi), spheres (phi / 2 pi, theta / pi)
/// about +z, mesh faces their vertex uvs (OBJ's v flipped) or, without, the
/// barycentric (b1, b2), whichever way the kernel reads the scene.
#[test]
fn texels_land_where_each_shapes_uvs_say() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("textures", "shapes");
    common::write_exr(&dir.join("map.exr"), 4, 4, distinct);
    let material = |wrap: &str, to_uv: &str| {
        format!(
            "[materials.m]\ntype = \"lambertian\"\nalbedo = {{ type = \"bitmap\", file = \"map.exr\", filter_type = \"nearest\", wrap_mode = \"{wrap}\"{to_uv} }}\n"
        )
    };
    let plain = material("repeat", "");
    let dv = |v: [f64; 3]| DVec3::from(v);
    let quad = |q: [f64; 3], u: [f64; 3], v: [f64; 3]| {
        format!("[[objects]]\ntype = \"quad\"\nq = {q:?}\nu = {u:?}\nv = {v:?}\nmaterial = \"m\"\n")
    };
    let front = ([0.4, 0.3, 2.5], [0.4, 0.45, 0.0], [0.0, 1.0, 0.0]);
    // A tilted quad.
    let (q, u, v) = ([-0.3, -0.2, 0.1], [1.4, 0.2, -0.3], [0.1, 1.3, 0.2]);
    let s = scene(&dir, &(plain.clone() + &quad(q, u, v)), front, 32, 4);
    let n = assert_uniform_pixels_exact(&s, &quad_uv(dv(q), dv(u), dv(v)), "quad");
    assert!(n > 256, "quad: {n} pixels checked");
    // Wrap modes: the quad's uv mapped onto [-1, 2]^2 by to_uv, so the map
    // repeats, mirrors or clamps around its one copy in [0, 1]^2.
    let (q, u, v) = ([-0.5, -0.5, 0.0], [1.8, 0.0, 0.0], [0.0, 1.8, 0.0]);
    for wrap in ["repeat", "mirror", "clamp"] {
        let body = material(wrap, ", to_uv = { scale = 3, translate = [-1, -1] }") + &quad(q, u, v);
        let s = scene(
            &dir,
            &body,
            ([0.4, 0.4, 2.5], [0.4, 0.4, 0.0], [0.0, 1.0, 0.0]),
            48,
            4,
        );
        let n = assert_uniform_pixels_exact(&s, &quad_uv(dv(q), dv(u), dv(v)), wrap);
        assert!(n > 576, "{wrap}: {n} pixels checked");
    }
    // A disk, an ellipse under a shear.
    let (c, u, v) = ([0.0, 0.0, 0.0], [1.0, 0.1, 0.0], [0.2, 0.9, 0.1]);
    let body = format!(
        "{plain}[[objects]]\ntype = \"disk\"\ncenter = {c:?}\nu = {u:?}\nv = {v:?}\nmaterial = \"m\"\n"
    );
    let s = scene(
        &dir,
        &body,
        ([0.2, 0.3, 3.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        32,
        4,
    );
    let n = assert_uniform_pixels_exact(&s, &disk_uv(dv(c), dv(u), dv(v)), "disk");
    assert!(n > 256, "disk: {n} pixels checked");
    // A sphere seen from the side: theta from pole to pole, phi across 0.
    let body = format!(
        "{plain}[[objects]]\ntype = \"sphere\"\ncenter = [0.1, 0, 0]\nradius = 1\nmaterial = \"m\"\n"
    );
    let s = scene(
        &dir,
        &body,
        ([4.0, 0.7, 0.4], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        32,
        4,
    );
    let n = assert_uniform_pixels_exact(&s, &sphere_uv(DVec3::new(0.1, 0.0, 0.0), 1.0), "sphere");
    assert!(n > 100, "sphere: {n} pixels checked");
    // A mesh face with uvs (OBJ: v up the image, so flipped) and one without.
    let p = [[-0.6, -0.5, 0.0], [1.3, -0.4, 0.1], [-0.2, 1.2, -0.1]];
    let vt = [[0.1, 0.9], [1.7, 0.8], [0.3, -0.6]];
    let mut obj = String::new();
    for v in p {
        obj += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    let with_uvs = obj.clone()
        + &vt
            .iter()
            .map(|t| format!("vt {} {}\n", t[0], t[1]))
            .collect::<String>()
        + "f 1/1 2/2 3/3\n";
    std::fs::write(dir.join("uvs.obj"), with_uvs).unwrap();
    std::fs::write(dir.join("plain.obj"), obj + "f 1 2 3\n").unwrap();
    let flipped = vt.map(|[u, v]| Vec2::new(u as f32, 1.0 - v as f32));
    let barycentric = [Vec2::ZERO, Vec2::X, Vec2::Y];
    for (file, uvs) in [("uvs.obj", flipped), ("plain.obj", barycentric)] {
        let body = format!(
            "{plain}[[objects]]\ntype = \"mesh\"\nfile = \"{file}\"\nsmooth = false\nmaterial = \"m\"\n"
        );
        let s = scene(
            &dir,
            &body,
            ([0.2, 0.2, 3.0], [0.2, 0.2, 0.0], [0.0, 1.0, 0.0]),
            32,
            4,
        );
        let n = assert_uniform_pixels_exact(&s, &triangle_uv(p.map(dv), uvs), file);
        assert!(n > 100, "{file}: {n} pixels checked");
    }
}

/// Bilinear filtering: each pixel is the mean of the bilinear lookup over its
/// footprint (a quad facing the camera squarely: uv is affine in the film
/// coordinates), which the host computes on a 16 x 16 grid; the render's own
/// integration error with 256 Sobol samples stays below 2e-3 (measured: 1.8e-4
/// at most), far below what one texel moved or a wrong weight gives.
#[test]
fn bilinear_lookups_weigh_the_four_nearest_texels() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let dir = common::TempDir::new("textures", "bilinear");
    common::write_exr(&dir.join("map.exr"), 3, 2, distinct);
    let (q, u, v) = ([-1.0, -1.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
    let shape = quad_uv(DVec3::from(q), DVec3::from(u), DVec3::from(v));
    let mut worst: f32 = 0.0;
    for wrap in ["repeat", "mirror", "clamp"] {
        let body = format!(
            "[materials.m]\ntype = \"lambertian\"\nalbedo = {{ type = \"bitmap\", file = \"map.exr\", wrap_mode = \"{wrap}\", to_uv = {{ matrix = [[2, 0.3, -0.5], [-0.2, 1.5, -0.4]] }} }}\n\
             [[objects]]\ntype = \"quad\"\nq = {q:?}\nu = {u:?}\nv = {v:?}\nmaterial = \"m\"\n"
        );
        let s = scene(
            &dir,
            &body,
            ([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
            24,
            256,
        );
        let texture = the_texture(&s);
        let lookup = |uv: Vec2| texture.eval(uv);
        let mean = common::render(ctx, &s, &RenderOptions::default()).mean();
        let mut checked = 0;
        for y in 0..24 {
            for x in 0..24 {
                let Some(values) = footprint(&s, &shape, &lookup, x, y, 16) else {
                    continue;
                };
                // The grid's points weighted as the trapezoid rule (corners and edges).
                let weight = |i: usize| if i == 0 || i == 16 { 0.5 } else { 1.0 };
                let mut sum = Vec3::ZERO;
                for (k, value) in values.iter().enumerate() {
                    sum += weight(k / 17) * weight(k % 17) * *value;
                }
                let expected = sum / 256.0;
                let got = Vec3::from(mean.pixels[(y * 24 + x) as usize]);
                let error = (got - expected).abs().max_element();
                worst = worst.max(error);
                assert!(
                    error < 2e-3,
                    "{wrap}: pixel ({x}, {y}) is {got}, expected {expected}"
                );
                checked += 1;
            }
        }
        assert!(checked > 300, "{wrap}: {checked} pixels checked");
    }
    eprintln!("bilinear: worst pixel error {worst}");
}

/// An 8-bit code's linear value (IEC 61966-2-1), in f64.
fn srgb(code: u8) -> f64 {
    let c = code as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// 8-bit images are sRGB-decoded (IEC 61966-2-1, computed here in f64), or
/// taken as code / 255 with `raw = true`; a JPEG of one flat colour decodes
/// to that colour (within a code of JPEG's rounding).
#[test]
fn eight_bit_images_decode_from_srgb() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let dir = common::TempDir::new("textures", "srgb");
    let codes: [[u8; 3]; 2] = [[128, 10, 255], [0, 64, 200]];
    let image = image::RgbImage::from_fn(2, 1, |x, _| image::Rgb(codes[x as usize]));
    image.save(dir.join("codes.png")).unwrap();
    image::RgbImage::from_pixel(8, 8, image::Rgb([128, 128, 128]))
        .save(dir.join("flat.jpg"))
        .unwrap();
    let (q, u, v) = ([-1.0, -1.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
    let shape = quad_uv(DVec3::from(q), DVec3::from(u), DVec3::from(v));
    let view = ([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
    let render = |texture: &str| {
        let body = format!(
            "[materials.m]\ntype = \"lambertian\"\nalbedo = {{ type = \"bitmap\", filter_type = \"nearest\", {texture} }}\n\
             [[objects]]\ntype = \"quad\"\nq = {q:?}\nu = {u:?}\nv = {v:?}\nmaterial = \"m\"\n"
        );
        let s = scene(&dir, &body, view, 16, 4);
        let mean = common::render(ctx, &s, &RenderOptions::default()).mean();
        (s, mean)
    };
    for raw in [false, true] {
        let (s, mean) = render(&format!("file = \"codes.png\", raw = {raw}"));
        let mut checked = 0;
        for y in 0..16 {
            for x in 0..16 {
                // Which texel (column) the footprint shows, if only one.
                let columns = footprint(
                    &s,
                    &shape,
                    &|uv: Vec2| Vec3::splat((uv.x * 2.0).floor()),
                    x,
                    y,
                    4,
                );
                let Some(columns) = columns else { continue };
                if columns.iter().any(|c| *c != columns[0]) {
                    continue;
                }
                let code = codes[columns[0].x as usize];
                let expected = code.map(|c| if raw { c as f64 / 255.0 } else { srgb(c) });
                let got = mean.pixels[(y * 16 + x) as usize];
                for c in 0..3 {
                    assert!(
                        (got[c] as f64 - expected[c]).abs() <= 1e-6,
                        "raw {raw}: pixel ({x}, {y}) is {got:?}, codes {code:?}"
                    );
                }
                checked += 1;
            }
        }
        assert!(checked > 64, "{checked} pixels checked");
    }
    let (_, mean) = render("file = \"flat.jpg\"");
    let (lo, hi) = (srgb(127), srgb(129));
    // The middle of the image, inside the quad.
    for y in 4..12 {
        for x in 4..12 {
            let pixel = mean.pixels[y * 16 + x];
            assert!(
                pixel.iter().all(|&c| (lo..=hi).contains(&(c as f64))),
                "{pixel:?}"
            );
        }
    }
}

/// An 8-bit image's texels are read as its codes and decoded in the kernel
/// (`kinds::TexelFormat`): the render is the same, bit for bit, as that of an
/// EXR holding the floats the host decodes them to (sRGB in f64 rounded to
/// f32, or code / 255), bilinearly filtered and mirrored, with each of the 256
/// codes in each channel. Beside a second quad with a float texture, the kernel
/// reads both formats.
#[test]
fn eight_bit_texels_decode_to_the_hosts_floats() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let dir = common::TempDir::new("textures", "bytes");
    let code = |x: u32, y: u32, channel: u32| ((16 * y + x) * (2 * channel + 1) % 256) as u8;
    let image =
        image::RgbImage::from_fn(16, 16, |x, y| image::Rgb([0, 1, 2].map(|c| code(x, y, c))));
    image.save(dir.join("codes.png")).unwrap();
    common::write_exr(&dir.join("other.exr"), 4, 4, distinct);
    let render = |file: &str, raw: bool| {
        let body = format!(
            "[materials.m]\ntype = \"lambertian\"\nalbedo = {{ type = \"bitmap\", file = \"{file}\", raw = {raw}, wrap_mode = \"mirror\", to_uv = {{ scale = 1.5, translate = [-0.2, -0.3] }} }}\n\
             [materials.other]\ntype = \"lambertian\"\nalbedo = {{ type = \"bitmap\", file = \"other.exr\" }}\n\
             [[objects]]\ntype = \"quad\"\nq = [-1.0, -1.0, 0.0]\nu = [1.5, 0.0, 0.0]\nv = [0.0, 2.0, 0.0]\nmaterial = \"m\"\n\
             [[objects]]\ntype = \"quad\"\nq = [0.6, -1.0, 0.0]\nu = [0.4, 0.0, 0.0]\nv = [0.0, 2.0, 0.0]\nmaterial = \"other\"\n"
        );
        let s = scene(
            &dir,
            &body,
            ([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
            48,
            4,
        );
        common::render(ctx, &s, &RenderOptions::default())
            .mean()
            .pixels
    };
    for raw in [false, true] {
        let decode = |c: u8| {
            if raw {
                c as f32 / 255.0
            } else {
                srgb(c) as f32
            }
        };
        let twin = format!("twin-{raw}.exr");
        common::write_exr(&dir.join(&twin), 16, 16, |x, y| {
            [0, 1, 2].map(|c| decode(code(x as u32, y as u32, c)))
        });
        let (bytes, floats) = (render("codes.png", raw), render(&twin, raw));
        assert!(bytes.iter().any(|p| p[0] != 1.0), "the quads are in view");
        assert_eq!(bytes, floats, "raw {raw}");
    }
}

/// A checkerboard multiplies what the material reflects and nothing else:
/// rendered with the same seed, each pixel of a checkerboard in `color0` and
/// `color1` is the pixel of the same material with that colour as a constant
/// to f32 rounding (1e-6 relative: the constant is compiled into its kernel,
/// where the compiler may fuse a multiply with it), for lambertian `albedo` and the conductors'
/// `specular_reflectance` (cells aligned with the pixels, 4 x 4 each). The
/// plastics are left out: their choice between lobes follows the texture's
/// mean, as Mitsuba's, so their samples differ from a constant's.
#[test]
fn checkerboard_pixels_equal_constant_colour_renders() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let dir = common::TempDir::new("textures", "checker");
    let (c0, c1) = ("[0.9, 0.6, 0.2]", "[0.15, 0.3, 0.7]");
    let checker = format!(
        "{{ type = \"checkerboard\", color0 = {c0}, color1 = {c1}, to_uv = {{ scale = 2 }} }}"
    );
    // The quad fills the 16 x 16 image exactly: uv = (row, column) / 16.
    let objects = "[[objects]]\ntype = \"quad\"\nq = [1, 1, 0]\nu = [0, -2, 0]\nv = [-2, 0, 0]\nmaterial = \"m\"\n";
    let kinds = [
        ("lambertian", "albedo", ""),
        ("conductor", "specular_reflectance", "material = \"Au\"\n"),
        (
            "roughconductor",
            "specular_reflectance",
            "material = \"Cu\"\nalpha = 0.3\n",
        ),
    ];
    for (kind, key, rest) in kinds {
        let render = |value: &str| {
            let body =
                format!("[materials.m]\ntype = \"{kind}\"\n{key} = {value}\n{rest}{objects}");
            let text = format!(
                "[camera]\nlookfrom = [0, 0, -1]\nlookat = [0, 0, 0]\nvfov = 90\nwidth = 16\nheight = 16\n\
                 [render]\nspp = 16\nmax_depth = 2\nstrategy = \"bsdf\"\nbackground = [1, 1, 1]\n{body}"
            );
            let path = dir.join("scene.toml");
            std::fs::write(&path, text).unwrap();
            let s = Scene::load(&path).unwrap();
            common::render(ctx, &s, &RenderOptions::default()).mean()
        };
        let textured = render(&checker);
        let constant = [render(c0), render(c1)];
        for y in 0..16 {
            for x in 0..16 {
                // uv = (y, x) / 16, scaled by 2: halves of 4 pixels.
                let cell = ((x / 4) + (y / 4)) % 2;
                let i = y * 16 + x;
                let (got, expected) = (textured.pixels[i], constant[cell].pixels[i]);
                for c in 0..3 {
                    assert!(
                        (got[c] - expected[c]).abs() <= 1e-6 * expected[c],
                        "{kind}: pixel ({x}, {y}) of cell {cell}: {got:?} != {expected:?}"
                    );
                }
            }
        }
    }
}

/// Bad texture input exits with code 2 before rendering, naming the scene
/// file, the field and the image file, and writes nothing.
#[test]
fn bad_texture_inputs_exit_2_naming_file_and_field() {
    let dir = common::TempDir::new("textures", "bad");
    let d = &dir;
    common::write_exr(&d.join("nan.exr"), 4, 2, |x, _| {
        if x == 3 {
            [f32::NAN, 0.5, 0.5]
        } else {
            [0.5; 3]
        }
    });
    common::write_exr(&d.join("negative.exr"), 4, 2, |_, y| {
        if y == 1 { [0.5, 0.5, -0.5] } else { [0.5; 3] }
    });
    common::write_exr(&d.join("good.exr"), 2, 2, |_, _| [0.5; 3]);
    std::fs::write(d.join("text.png"), "not an image\n").unwrap();
    std::fs::write(d.join("map.bmp"), "BM").unwrap();
    std::fs::create_dir_all(d.join("folder.png")).unwrap();
    let bitmap = |rest: &str| format!("{{ type = \"bitmap\", {rest} }}");
    let cases = [
        (
            bitmap("file = \"missing.png\""),
            "albedo.file",
            "missing.png: cannot read",
        ),
        (
            bitmap("file = \"folder.png\""),
            "albedo.file",
            "folder.png: cannot",
        ),
        (
            bitmap("file = \"text.png\""),
            "albedo.file",
            "text.png: cannot decode",
        ),
        (
            bitmap("file = \"map.bmp\""),
            "albedo.file",
            "unknown texture image format",
        ),
        (
            bitmap("file = \"nan.exr\""),
            "albedo.file",
            "nan.exr: texel (3, 0)",
        ),
        (
            bitmap("file = \"negative.exr\""),
            "albedo.file",
            "negative.exr: texel (0, 1)",
        ),
        (
            bitmap("file = \"good.exr\", wrap_mode = \"wrap\""),
            "albedo.wrap_mode",
            "unknown wrap_mode `wrap`",
        ),
        (
            bitmap("file = \"good.exr\", filter_type = \"cubic\""),
            "albedo.filter_type",
            "unknown filter_type",
        ),
        (
            bitmap("wrap_mode = \"clamp\""),
            "albedo",
            "missing required key `file`",
        ),
        (
            "{ type = \"marble\" }".to_string(),
            "albedo.type",
            "unknown texture type",
        ),
        (
            "{ type = \"checkerboard\", color0 = 2 }".to_string(),
            "albedo.color0",
            "",
        ),
        (
            "{ type = \"checkerboard\", to_uv = { matrix = [1, 2] } }".to_string(),
            "albedo.to_uv.matrix",
            "two rows of three numbers",
        ),
    ];
    for (i, (albedo, field, problem)) in cases.iter().enumerate() {
        let name = format!("case{i}.toml");
        let scene_path = d.join(&name);
        std::fs::write(
            &scene_path,
            format!(
                "[camera]\nlookfrom = [0, 0, -5]\nlookat = [0, 0, 0]\nwidth = 4\nheight = 4\n\
                 [materials.m]\ntype = \"lambertian\"\nalbedo = {albedo}\n\
                 [[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n"
            ),
        )
        .unwrap();
        let out = d.join(format!("case{i}.png"));
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_pathmix"))
            .args([
                "render",
                scene_path.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let message = String::from_utf8_lossy(&output.stderr).into_owned();
        assert_eq!(output.status.code(), Some(2), "{albedo}: {message}");
        assert!(!out.exists(), "{albedo}: an image was written");
        for part in [name.as_str(), &format!("materials.m.{field}"), problem] {
            assert!(message.contains(part), "{albedo}: no {part:?} in {message}");
        }
    }
}
