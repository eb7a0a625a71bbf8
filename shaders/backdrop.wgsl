// The soft background (a sky gradient behind everything) and the ground: a
// large square under the cloth with a metric grid that fades with distance.

const SKY_TOP: vec3<f32> = vec3<f32>(0.34, 0.44, 0.58);
const SKY_HORIZON: vec3<f32> = vec3<f32>(0.80, 0.82, 0.84);
const FLOOR_FAR: vec3<f32> = vec3<f32>(0.56, 0.56, 0.56);
const GROUND: vec3<f32> = vec3<f32>(0.60, 0.60, 0.59);
const GRID_MINOR: vec3<f32> = vec3<f32>(0.52, 0.52, 0.52);
const GRID_MAJOR: vec3<f32> = vec3<f32>(0.40, 0.40, 0.41);

struct SkyOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) ndc: vec2<f32>,
}

// One triangle that covers the viewport.
@vertex
fn vs_sky(@builtin(vertex_index) index: u32) -> SkyOut {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    let ndc = uv * 2.0 - 1.0;
    var out: SkyOut;
    out.clip = vec4<f32>(ndc, 1.0, 1.0);
    out.ndc = ndc;
    return out;
}

fn sky_colour(dir: vec3<f32>) -> vec3<f32> {
    if dir.y < 0.0 {
        return mix(SKY_HORIZON, FLOOR_FAR, clamp(-dir.y * 6.0, 0.0, 1.0));
    }
    return mix(SKY_HORIZON, SKY_TOP, pow(clamp(dir.y, 0.0, 1.0), 0.6));
}

@fragment
fn fs_sky(in: SkyOut) -> @location(0) vec4<f32> {
    let far = frame.inv_view_proj * vec4<f32>(in.ndc, 1.0, 1.0);
    let dir = normalize(far.xyz / far.w - frame.eye.xyz);
    return output(sky_colour(dir), 1.0);
}

struct GroundOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
}

// A square of side 2 × fade radius centred under the cloth, as a triangle strip.
@vertex
fn vs_ground(@builtin(vertex_index) index: u32) -> GroundOut {
    let corner = vec2<f32>(f32(index & 1u), f32((index >> 1u) & 1u)) * 2.0 - 1.0;
    let r = frame.ground.z;
    let world = vec3<f32>(frame.centre.x + corner.x * r, frame.ground.x, frame.centre.z + corner.y * r);
    var out: GroundOut;
    out.clip = frame.view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    return out;
}

// Coverage of grid lines `spacing` apart and about `pixels` wide, anti-aliased.
fn grid_lines(p: vec2<f32>, spacing: f32, pixels: f32) -> f32 {
    let q = p / spacing;
    let w = max(fwidth(q), vec2<f32>(1e-5));
    let d = abs(fract(q - 0.5) - 0.5) / w;
    let line = 1.0 - min(min(d.x, d.y) / pixels, 1.0);
    // Lines closer than a few pixels apart would moiré: fade them out.
    let density = clamp(1.5 - max(w.x, w.y) * 6.0, 0.0, 1.0);
    return line * density;
}

@fragment
fn fs_ground(in: GroundOut) -> @location(0) vec4<f32> {
    let p = in.world.xz;
    let major = frame.ground.y;
    var c = GROUND;
    c = mix(c, GRID_MINOR, grid_lines(p, major * 0.2, 1.0));
    c = mix(c, GRID_MAJOR, grid_lines(p, major, 1.3));
    // Fade into the far floor colour towards the edge of the square.
    let dist = length(p - frame.centre.xz) / frame.ground.z;
    let view = normalize(in.world - frame.eye.xyz);
    let fade = smoothstep(0.35, 1.0, dist);
    c = mix(c, sky_colour(view), fade);
    return output(c, 1.0);
}
