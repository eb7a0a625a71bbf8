// Bars as screen-space ribbons a few pixels wide, one instance per bar,
// coloured by strain or by kind.

struct BarIn {
    @location(0) a: vec3<f32>,
    @location(1) strain: f32,
    @location(2) b: vec3<f32>,
    // 0 structural, 1 bend.
    @location(3) kind: f32,
}

struct BarOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) colour: vec3<f32>,
}

const STRUCTURAL_COLOUR: vec3<f32> = vec3<f32>(0.10, 0.12, 0.16);
const BEND_COLOUR: vec3<f32> = vec3<f32>(0.72, 0.45, 0.08);

// Moves a clip-space end that lies behind the near plane onto it, along the bar.
fn clip_to_near(p: vec4<f32>, other: vec4<f32>) -> vec4<f32> {
    let near = 1e-4;
    if p.w >= near {
        return p;
    }
    let t = (near - p.w) / (other.w - p.w);
    return mix(p, other, t);
}

@vertex
fn vs_bar(@builtin(vertex_index) index: u32, bar: BarIn) -> BarOut {
    let ca0 = frame.view_proj * vec4<f32>(bar.a, 1.0);
    let cb0 = frame.view_proj * vec4<f32>(bar.b, 1.0);
    let ca = clip_to_near(ca0, cb0);
    let cb = clip_to_near(cb0, ca0);
    // Two triangles: corners 0..5 → (end, side).
    let ends = array<f32, 6>(0.0, 0.0, 1.0, 0.0, 1.0, 1.0);
    let sides = array<f32, 6>(-1.0, 1.0, 1.0, -1.0, 1.0, -1.0);
    let end = ends[index];
    let side = sides[index];
    let size = frame.viewport.xy;
    let sa = ca.xy / ca.w * size;
    let sb = cb.xy / cb.w * size;
    var dir = sb - sa;
    if dot(dir, dir) < 1e-8 {
        dir = vec2<f32>(1.0, 0.0);
    }
    let normal = normalize(vec2<f32>(-dir.y, dir.x));
    var width = frame.style.z;
    if bar.kind > 0.5 {
        width = max(width * 0.6, 1.0);
    }
    let c = mix(ca, cb, end);
    // Half the width on each side, in NDC (which spans 2 across the viewport).
    let offset = normal * side * width / size;
    var out: BarOut;
    out.clip = pull_forward(vec4<f32>(c.xy + offset * c.w, c.z, c.w));
    if frame.style.y > 0.5 {
        out.colour = strain_colour(bar.strain);
    } else if bar.kind > 0.5 {
        out.colour = BEND_COLOUR;
    } else {
        out.colour = STRUCTURAL_COLOUR;
    }
    return out;
}

@fragment
fn fs_bar(in: BarOut) -> @location(0) vec4<f32> {
    return output(in.colour, 1.0);
}
