// Colliders: opaque, lit in a neutral grey-blue so the cloth stands out,
// and their shadow on the ground (drawn through the same stencil as the
// cloth's, so the two darken the ground once).

struct ColliderIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

struct ColliderOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

const COLLIDER_COLOUR: vec3<f32> = vec3<f32>(0.46, 0.50, 0.56);
const COLLIDER_SKY: vec3<f32> = vec3<f32>(0.58, 0.61, 0.66);
const COLLIDER_FLOOR: vec3<f32> = vec3<f32>(0.28, 0.26, 0.24);

@vertex
fn vs_collider(v: ColliderIn) -> ColliderOut {
    var out: ColliderOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    return out;
}

@fragment
fn fs_collider(in: ColliderOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    var n = normalize(in.normal + vec3<f32>(0.0, 1e-6, 0.0));
    if !front {
        n = -n;
    }
    let l = frame.light_dir.xyz;
    let v = normalize(frame.eye.xyz - in.world);
    let diffuse = max(dot(n, l), 0.0);
    let hemi = mix(COLLIDER_FLOOR, COLLIDER_SKY, 0.5 + 0.5 * n.y);
    let h = normalize(l + v);
    let gloss = 0.18 * pow(max(dot(n, h), 0.0), 40.0);
    let lit = COLLIDER_COLOUR * (0.85 * diffuse + 0.45 * hemi) + vec3<f32>(gloss);
    return output(lit, 1.0);
}

@vertex
fn vs_collider_shadow(v: ColliderIn) -> @builtin(position) vec4<f32> {
    let l = frame.light_dir.xyz;
    let ground = frame.ground.x + frame.centre.y;
    let t = max(v.position.y - ground, 0.0) / max(l.y, 0.05);
    let p = vec3<f32>(v.position.x - l.x * t, ground, v.position.z - l.z * t);
    return frame.view_proj * vec4<f32>(p, 1.0);
}

@fragment
fn fs_collider_shadow() -> @location(0) vec4<f32> {
    return vec4<f32>(0.0, 0.0, 0.0, 0.25);
}
