// Shared by every drape shader: the per-frame uniform block, colour output
// and the strain colour ramp. `render::shaders` prepends this file to each
// of the others, so they are never compiled alone.

struct Frame {
    // World to clip space, and back (the backdrop casts rays with it).
    view_proj: mat4x4<f32>,
    inv_view_proj: mat4x4<f32>,
    // xyz: the camera's position in world space.
    eye: vec4<f32>,
    // xyz: unit vector towards the key light.
    light_dir: vec4<f32>,
    // xy: viewport size in pixels; z: 1 when the shader must encode sRGB
    // itself (the target format is not *Srgb); w: pixels per point.
    viewport: vec4<f32>,
    // x: ground height y; y: major grid spacing in metres; z: radius over
    // which the ground fades out; w: checker cell size in metres.
    ground: vec4<f32>,
    // xz: the centre of the ground under the cloth; y: shadow lift in metres.
    centre: vec4<f32>,
    // x: the strain shown at the top of the ramp; y: 1 to colour the surface
    // by strain; z: bar width in pixels; w: particle radius in pixels.
    style: vec4<f32>,
    // Five colours from strain 0 to style.x, linear RGB.
    ramp: array<vec4<f32>, 5>,
}

@group(0) @binding(0) var<uniform> frame: Frame;

// Linear RGB to sRGB, for targets that do not convert on store.
fn encode_srgb(c: vec3<f32>) -> vec3<f32> {
    let lo = c * 12.92;
    let hi = 1.055 * pow(max(c, vec3<f32>(0.0)), vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}

// What a fragment shader returns for a linear colour and an alpha.
fn output(c: vec3<f32>, alpha: f32) -> vec4<f32> {
    if frame.viewport.z > 0.5 {
        return vec4<f32>(encode_srgb(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0))), alpha);
    }
    return vec4<f32>(c, alpha);
}

// The strain colour ramp: strain 0 maps to ramp[0], style.x and more to ramp[4].
fn strain_colour(strain: f32) -> vec3<f32> {
    let t = clamp(strain / max(frame.style.x, 1e-9), 0.0, 1.0) * 4.0;
    let i = min(u32(floor(t)), 3u);
    return mix(frame.ramp[i].rgb, frame.ramp[i + 1u].rgb, t - f32(i));
}

// Pulls a clip-space position a little towards the camera so that lines and
// points drawn on the surface win the depth test without z-fighting.
fn pull_forward(clip: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(clip.xy, clip.z - 2e-4 * clip.w, clip.w);
}
