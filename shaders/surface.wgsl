// The cloth as a lit, two-sided surface, and its shadow on the ground.

struct SurfaceIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    // The particle's rest position in the cloth's own plane (metres): the
    // checker lives here, so it stretches and folds with the cloth.
    @location(2) material: vec2<f32>,
    @location(3) strain: f32,
}

struct SurfaceOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) material: vec2<f32>,
    @location(3) strain: f32,
}

const FRONT_COLOUR: vec3<f32> = vec3<f32>(0.72, 0.16, 0.07);
const BACK_COLOUR: vec3<f32> = vec3<f32>(0.10, 0.24, 0.52);
const SKY_LIGHT: vec3<f32> = vec3<f32>(0.58, 0.61, 0.66);
const GROUND_LIGHT: vec3<f32> = vec3<f32>(0.28, 0.26, 0.24);
const CHECKER_CONTRAST: f32 = 0.16;

@vertex
fn vs_surface(v: SurfaceIn) -> SurfaceOut {
    var out: SurfaceOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.material = v.material;
    out.strain = v.strain;
    return out;
}

// 1 on one colour of the checker, 0 on the other, blended over a pixel at
// the cell borders so that a distant, dense checker fades to grey instead of
// aliasing.
fn checker(material: vec2<f32>, cell: f32) -> f32 {
    let p = material / cell;
    let width = max(fwidth(p), vec2<f32>(1e-4));
    // A triangle wave per axis, its sign is the checker; smoothed over a pixel.
    let tri = abs(fract(p * 0.5) - 0.5) * 2.0 - 0.5;
    let s = clamp(tri / width, vec2<f32>(-1.0), vec2<f32>(1.0));
    // Fade to the mean where a cell is smaller than a couple of pixels.
    let fade = clamp(1.5 - max(width.x, width.y) * 2.0, 0.0, 1.0);
    return 0.5 + 0.5 * s.x * s.y * fade;
}

@fragment
fn fs_surface(in: SurfaceOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    var n = normalize(in.normal + vec3<f32>(0.0, 1e-6, 0.0));
    var base = FRONT_COLOUR;
    if !front {
        n = -n;
        base = BACK_COLOUR;
    }
    if frame.style.y > 0.5 {
        base = strain_colour(in.strain);
    }
    let c = checker(in.material, frame.ground.w);
    base = base * (1.0 - CHECKER_CONTRAST * 0.5 + CHECKER_CONTRAST * c);

    let l = frame.light_dir.xyz;
    let v = normalize(frame.eye.xyz - in.world);
    // Wrapped diffuse keeps the unlit side readable; the hemisphere term is
    // the sky above and the floor below.
    let diffuse = max((dot(n, l) + 0.25) / 1.25, 0.0);
    let hemi = mix(GROUND_LIGHT, SKY_LIGHT, 0.5 + 0.5 * n.y);
    let h = normalize(l + v);
    let sheen = 0.10 * pow(max(dot(n, h), 0.0), 24.0);
    // Grazing views darken a little, which brings out folds.
    let facing = 0.80 + 0.20 * abs(dot(n, v));
    let lit = base * (0.95 * diffuse + 0.40 * hemi) * facing + vec3<f32>(sheen);
    return output(lit, 1.0);
}

// The cloth flattened onto the ground along the light, drawn with a stencil
// test so that overlapping layers darken only once.
@vertex
fn vs_shadow(v: SurfaceIn) -> @builtin(position) vec4<f32> {
    let l = frame.light_dir.xyz;
    let ground = frame.ground.x + frame.centre.y;
    let t = (v.position.y - ground) / max(l.y, 0.05);
    let p = vec3<f32>(v.position.x - l.x * t, ground, v.position.z - l.z * t);
    return frame.view_proj * vec4<f32>(p, 1.0);
}

@fragment
fn fs_shadow() -> @location(0) vec4<f32> {
    // Premultiplied black: darkens what is below by a quarter.
    return vec4<f32>(0.0, 0.0, 0.0, 0.25);
}

// The triangle edges as thin lines over the surface.
@vertex
fn vs_wireframe(v: SurfaceIn) -> @builtin(position) vec4<f32> {
    return pull_forward(frame.view_proj * vec4<f32>(v.position, 1.0));
}

@fragment
fn fs_wireframe() -> @location(0) vec4<f32> {
    return output(vec3<f32>(0.05, 0.05, 0.06), 1.0);
}
