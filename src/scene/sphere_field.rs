//! The benchmarks' scene of many spheres, generated for any count: the scale
//! curve of `pathmix bench`, and a scene file for other renderers.

use super::Scene;

/// `n` small diffuse spheres in a grid on a ground sphere, under a sky colour
/// and a sphere light: how the cost grows with the scene (256x256, max depth 8).
pub fn sphere_field(n: usize) -> Scene {
    Scene::parse(&sphere_field_toml(n), "sphere-field.toml")
        .expect("the sphere field is a valid scene")
}

/// The scene file of `sphere_field(n)`, as `pathmix bench --write-sphere-field`
/// prints it for other renderers (`scripts/compare-mitsuba.py`).
pub fn sphere_field_toml(n: usize) -> String {
    let mut text = format!(
        "# A field of {n} diffuse spheres on a ground sphere under a sky colour and a sphere\n\
         # light: `pathmix bench --write-sphere-field {n}`, the scale curve's scene.\n\
         [camera]\nlookfrom = [0, 6, 14]\nlookat = [0, 0, 0]\nwidth = 256\nheight = 256\n\
         [render]\nmax_depth = 8\nbackground = [0.5, 0.7, 1.0]\n\
         [materials.ground]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [materials.ball]\ntype = \"lambertian\"\nalbedo = [0.7, 0.3, 0.2]\n\
         [materials.lamp]\ntype = \"light\"\nemit = [10, 10, 10]\n\
         [[objects]]\ntype = \"sphere\"\ncenter = [0, -1000, 0]\nradius = 1000\nmaterial = \"ground\"\n\
         [[objects]]\ntype = \"sphere\"\ncenter = [0, 12, 0]\nradius = 2\nmaterial = \"lamp\"\n",
    );
    let side = (n as f64).sqrt().ceil() as usize;
    let radius = 0.35 * 10.0 / side as f64;
    for i in 0..n {
        let x = (i % side) as f64 / side as f64 * 20.0 - 10.0;
        let z = (i / side) as f64 / side as f64 * 20.0 - 10.0;
        text.push_str(&format!(
            "[[objects]]\ntype = \"sphere\"\ncenter = [{x}, {radius}, {z}]\nradius = {radius}\nmaterial = \"ball\"\n"
        ));
    }
    text
}
