// Particles as round screen-space dots, one instance per particle. Fixed
// particles are larger red discs with a dark rim; the grabbed one is yellow.

struct PointIn {
    @location(0) position: vec3<f32>,
    // Bit 0: fixed; bit 1: grabbed or hovered.
    @location(1) flags: u32,
}

struct PointOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) corner: vec2<f32>,
    @location(1) @interpolate(flat) flags: u32,
}

const FREE_COLOUR: vec3<f32> = vec3<f32>(0.95, 0.95, 0.92);
const FIXED_COLOUR: vec3<f32> = vec3<f32>(0.85, 0.10, 0.10);
const GRABBED_COLOUR: vec3<f32> = vec3<f32>(1.00, 0.82, 0.10);
const RIM_COLOUR: vec3<f32> = vec3<f32>(0.08, 0.08, 0.08);

@vertex
fn vs_point(@builtin(vertex_index) index: u32, p: PointIn) -> PointOut {
    let xs = array<f32, 6>(-1.0, 1.0, 1.0, -1.0, 1.0, -1.0);
    let ys = array<f32, 6>(-1.0, -1.0, 1.0, -1.0, 1.0, 1.0);
    let corner = vec2<f32>(xs[index], ys[index]);
    var radius = frame.style.w;
    if (p.flags & 1u) != 0u {
        radius = radius * 1.5;
    }
    if (p.flags & 2u) != 0u {
        radius = radius * 2.2;
    }
    let c = frame.view_proj * vec4<f32>(p.position, 1.0);
    var out: PointOut;
    out.clip = pull_forward(vec4<f32>(c.xy + corner * radius / frame.viewport.xy * 2.0 * c.w, c.z, c.w));
    if c.w <= 0.0 {
        // Behind the camera: a degenerate triangle draws nothing.
        out.clip = vec4<f32>(0.0, 0.0, 2.0, 1.0);
    }
    out.corner = corner;
    out.flags = p.flags;
    return out;
}

@fragment
fn fs_point(in: PointOut) -> @location(0) vec4<f32> {
    let r = length(in.corner);
    if r > 1.0 {
        discard;
    }
    var colour = FREE_COLOUR;
    if (in.flags & 1u) != 0u {
        colour = FIXED_COLOUR;
    }
    if (in.flags & 2u) != 0u {
        colour = GRABBED_COLOUR;
    }
    if r > 0.75 {
        colour = RIM_COLOUR;
    }
    return output(colour, 1.0);
}
