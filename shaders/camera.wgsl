// Camera rays: where each sample's ray leaves the camera, and the weight the
// pixel filter gives it (`kinds::filter`). The path kernel and the AOV pass
// (`aov.wgsl`) draw them alike.

// A camera ray, the weight its sample carries (filter importance sampling:
// the offset from the pixel centre is drawn from the pixel filter) and, for
// splatting, where in its pixel it left ([0, 1)^2).
struct CameraRay {
    ray: Ray,
    weight: f32,
    position: vec2<f32>,
}

fn camera_ray(pixel: vec2<u32>) -> CameraRay {
#if FILTER_OFFSET
#if SPLAT
    // An adaptive kernel splats its uniform rounds and draws offsets in the others.
    if params.splatting != 0u {
        return jittered_camera_ray(pixel);
    }
#endif
    // The scene's filter (`shaders/filter.wgsl`).
    let offset = filter_offset(sample_2d());
    let to_film = params.to_pixel00
        + (f32(pixel.x) + offset.x) * params.delta_u
        + (f32(pixel.y) + offset.y) * params.delta_v;
    return CameraRay(camera_ray_through(to_film), offset.z, offset.xy + 0.5);
#else
    return jittered_camera_ray(pixel);
#endif
}

// Box filter, or splatting (which weighs the sample into every pixel its filter
// reaches, splat.wgsl): a uniformly jittered point of the pixel.
fn jittered_camera_ray(pixel: vec2<u32>) -> CameraRay {
    let jitter = sample_2d();
    let to_film = params.to_pixel00
        + (f32(pixel.x) + jitter.x - 0.5) * params.delta_u
        + (f32(pixel.y) + jitter.y - 0.5) * params.delta_v;
    return CameraRay(camera_ray_through(to_film), 1.0, jitter);
}

// The ray through the point `to_film` of the image plane (from the eye, which
// the plane is 1 ahead of; for the orthographic view, the plane through it).
fn camera_ray_through(to_film: vec3<f32>) -> Ray {
#if ORTHOGRAPHIC
    // Mitsuba's `orthographic`: along the view axis (delta_u x delta_v: the
    // image's right is u and its rows go down v, so u x -v = -w), from the
    // point of the plane through the eye.
    return Ray(params.origin + to_film, normalize(cross(params.delta_u, params.delta_v)));
#else
#if THIN_LENS
    // Mitsuba's `thinlens`: from a uniform point of the lens disk (the path's
    // second sample dimension, after the pixel's) through the point the pinhole
    // ray meets on the plane in focus; its weight stays 1. `to_film` is 1
    // along the view axis, so that plane is `focus_distance` ahead.
    let disk = params.lens_radius * square_to_disk_concentric(sample_2d());
    let lens = disk.x * normalize(params.delta_u) + disk.y * normalize(params.delta_v);
    return Ray(params.origin + lens, normalize(params.focus_distance * to_film - lens));
#else
    return Ray(params.origin, normalize(to_film));
#endif
#endif
}
