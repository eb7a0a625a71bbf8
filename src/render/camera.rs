//! [`OrbitCamera`]: a camera that circles a target point, as 3-D tools do,
//! with the maths for orbiting, panning, zooming, fitting and picking rays.

use glam::{Mat4, Vec2, Vec3};

use crate::scene::CameraHint;

/// Highest elevation, radians: just short of straight down, where yaw would
/// become meaningless.
const MAX_PITCH: f32 = 89.0 * std::f32::consts::PI / 180.0;
/// Radians of orbit per pixel of mouse drag.
const ORBIT_PER_PIXEL: f32 = 0.008;
/// How much further than a tight fit [`OrbitCamera::fit`] puts the camera.
const FIT_MARGIN: f32 = 1.1;
/// Closest and furthest the camera may get, metres.
const DISTANCE_RANGE: (f32, f32) = (1e-3, 1e6);
/// The view shape a scene's `[camera] distance` is chosen for (16:10); a
/// narrower view moves the camera back so the same width stays in view.
const HINT_ASPECT: f32 = 1.6;

/// A perspective camera looking at `target` from `distance` away, at an
/// angle given by `yaw` and `pitch`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// The point looked at and orbited, metres.
    pub target: Vec3,
    /// Rotation about +y, radians; 0 puts the camera on the +z side looking
    /// along −z, positive values move it towards +x.
    pub yaw: f32,
    /// Elevation, radians; positive looks down. Kept within ±89°.
    pub pitch: f32,
    /// From the target to the eye, metres.
    pub distance: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

/// A half-line in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where it starts (on the near plane).
    pub origin: Vec3,
    /// Unit direction.
    pub direction: Vec3,
}

impl Ray {
    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }

    /// Where the ray meets the plane through `point` with normal `normal`;
    /// `None` if it runs parallel to it or the plane is behind.
    pub fn hit_plane(&self, point: Vec3, normal: Vec3) -> Option<Vec3> {
        let denom = self.direction.dot(normal);
        if denom.abs() < 1e-9 {
            return None;
        }
        let t = (point - self.origin).dot(normal) / denom;
        (t >= 0.0).then(|| self.at(t))
    }

    /// The distance along the ray to triangle `(a, b, c)` (either side), if
    /// it is hit (Möller–Trumbore).
    pub fn hit_triangle(&self, a: Vec3, b: Vec3, c: Vec3) -> Option<f32> {
        let e1 = b - a;
        let e2 = c - a;
        let p = self.direction.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            return None;
        }
        let inv = 1.0 / det;
        let s = self.origin - a;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(e1);
        let v = self.direction.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = e2.dot(q) * inv;
        (t > 0.0).then_some(t)
    }
}

impl Default for OrbitCamera {
    fn default() -> Self {
        Self { target: Vec3::ZERO, yaw: 0.0, pitch: 0.0, distance: 5.0, fov_y: 40f32.to_radians() }
    }
}

impl OrbitCamera {
    /// The scene's suggested view of a cloth with bounds `(min, max)`: its
    /// angles, and its distance and target or, where the hint leaves them
    /// out, a view that fits the whole cloth for a viewport of `aspect`.
    pub fn from_hint(hint: &CameraHint, bounds: (Vec3, Vec3), aspect: f32) -> Self {
        let mut camera = Self {
            yaw: hint.yaw_degrees.to_radians(),
            pitch: hint.pitch_degrees.to_radians().clamp(-MAX_PITCH, MAX_PITCH),
            ..Self::default()
        };
        camera.fit(bounds, aspect);
        if let Some(target) = hint.target {
            camera.target = target;
        }
        if let Some(distance) = hint.distance {
            let narrower = (HINT_ASPECT / aspect.max(1e-3)).max(1.0);
            camera.distance = (distance * narrower).clamp(DISTANCE_RANGE.0, DISTANCE_RANGE.1);
        }
        camera
    }

    /// Keeps the angles and moves so that the box `(min, max)` fills the view.
    pub fn fit(&mut self, (min, max): (Vec3, Vec3), aspect: f32) {
        let radius = (0.5 * (max - min).length()).max(1e-3);
        let half_y = 0.5 * self.fov_y;
        let half_x = (half_y.tan() * aspect.max(1e-3)).atan();
        let half = half_y.min(half_x);
        self.target = 0.5 * (min + max);
        // A sphere of this radius just touches the narrower side of the view;
        // the box inside it leaves a margin, and a little more for the cloth
        // to swing into.
        self.distance = (FIT_MARGIN * radius / half.sin()).clamp(DISTANCE_RANGE.0, DISTANCE_RANGE.1);
    }

    /// Unit vector from the target towards the eye.
    pub fn backward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(sy * cp, sp, cy * cp)
    }

    /// Raises the pitch, if needed, so the eye stays above the plane y =
    /// `height` (by 2 % of the distance): the camera never looks from under
    /// a ground it could not see through. A target below the ground cannot
    /// be helped and is left alone.
    pub fn keep_above(&mut self, height: f32) {
        let need = (height + 0.02 * self.distance - self.target.y) / self.distance;
        if need < 1.0 {
            let lowest = need.max(-1.0).asin().min(MAX_PITCH);
            self.pitch = self.pitch.max(lowest);
        }
    }

    /// The eye's position.
    pub fn eye(&self) -> Vec3 {
        self.target + self.backward() * self.distance
    }

    /// The world-to-view transform (right-handed, y up).
    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye(), self.target, Vec3::Y)
    }

    /// The projection for a viewport of `aspect` (width / height); depth
    /// covers everything within `world_radius` of the target.
    pub fn projection(&self, aspect: f32, world_radius: f32) -> Mat4 {
        let far = 1.5 * (self.distance + world_radius.max(self.distance));
        let near = (self.distance * 0.01).max(far * 1e-5);
        // wgpu's clip space is Direct3D's: depth 0..1, y up.
        glam::camera::rh::proj::directx::perspective(self.fov_y, aspect.max(1e-3), near, far)
    }

    /// Projection times view.
    pub fn view_projection(&self, aspect: f32, world_radius: f32) -> Mat4 {
        self.projection(aspect, world_radius) * self.view()
    }

    /// Turns the camera about its target by a mouse drag of `delta` pixels.
    pub fn orbit(&mut self, delta: Vec2) {
        self.yaw -= delta.x * ORBIT_PER_PIXEL;
        self.pitch = (self.pitch + delta.y * ORBIT_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Slides the camera and its target sideways so that the point under the
    /// cursor follows a drag of `delta` pixels in a viewport `height` pixels high.
    pub fn pan(&mut self, delta: Vec2, height: f32) {
        let metres_per_pixel = 2.0 * self.distance * (0.5 * self.fov_y).tan() / height.max(1.0);
        let back = self.backward();
        let right = Vec3::Y.cross(back).normalize_or(Vec3::X);
        let up = back.cross(right);
        self.target += (-right * delta.x + up * delta.y) * metres_per_pixel;
    }

    /// Moves closer (positive `steps`) or further, by 10 % per step.
    pub fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * 0.9f32.powf(steps)).clamp(DISTANCE_RANGE.0, DISTANCE_RANGE.1);
    }

    /// The ray through pixel `pixel` of a viewport of `size` pixels (origin
    /// top-left), for a projection built with the same `world_radius`.
    pub fn ray(&self, pixel: Vec2, size: Vec2, world_radius: f32) -> Ray {
        let inverse = self.view_projection(size.x / size.y.max(1.0), world_radius).inverse();
        let ndc = Vec2::new(2.0 * pixel.x / size.x.max(1.0) - 1.0, 1.0 - 2.0 * pixel.y / size.y.max(1.0));
        let near = inverse.project_point3(ndc.extend(0.0));
        let far = inverse.project_point3(ndc.extend(1.0));
        Ray { origin: near, direction: (far - near).normalize_or(-self.backward()) }
    }

    /// Where `point` lands in a viewport of `size` pixels (origin top-left),
    /// and its distance in front of the eye; `None` if it is behind the eye.
    pub fn project(&self, point: Vec3, size: Vec2, world_radius: f32) -> Option<(Vec2, f32)> {
        let clip = self.view_projection(size.x / size.y.max(1.0), world_radius) * point.extend(1.0);
        if clip.w <= 0.0 {
            return None;
        }
        let ndc = clip.truncate() / clip.w;
        let pixel = Vec2::new((ndc.x + 1.0) * 0.5 * size.x, (1.0 - ndc.y) * 0.5 * size.y);
        Some((pixel, clip.w))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-4
    }

    #[test]
    fn hinted_distance_is_for_a_16_to_10_view_and_backs_off_when_narrower() {
        let hint = CameraHint { distance: Some(40.0), ..CameraHint::default() };
        let bounds = (Vec3::ZERO, Vec3::ONE);
        assert_eq!(OrbitCamera::from_hint(&hint, bounds, 1.6).distance, 40.0);
        assert_eq!(OrbitCamera::from_hint(&hint, bounds, 2.4).distance, 40.0);
        // Half as wide: twice as far, so the same width fits.
        assert!((OrbitCamera::from_hint(&hint, bounds, 0.8).distance - 80.0).abs() < 1e-3);
    }

    #[test]
    fn yaw_zero_looks_along_minus_z_and_pitch_looks_down() {
        let cam = OrbitCamera { pitch: 0.3, ..OrbitCamera::default() };
        let eye = cam.eye();
        assert!(eye.z > 0.0 && eye.y > 0.0 && eye.x.abs() < 1e-6, "{eye}");
        let turned = OrbitCamera { yaw: 0.5, ..OrbitCamera::default() };
        assert!(turned.eye().x > 0.0);
    }

    #[test]
    fn the_target_projects_to_the_centre_and_its_ray_comes_back() {
        let cam = OrbitCamera { target: Vec3::new(1.0, 2.0, 3.0), yaw: 0.7, pitch: 0.2, ..OrbitCamera::default() };
        let size = Vec2::new(640.0, 480.0);
        let (pixel, depth) = cam.project(cam.target, size, 10.0).unwrap();
        assert!((pixel - size / 2.0).length() < 1e-3, "{pixel}");
        assert!((depth - cam.distance).abs() < 1e-3);
        let ray = cam.ray(Vec2::new(100.0, 70.0), size, 10.0);
        let p = ray.at(4.0);
        let (back, _) = cam.project(p, size, 10.0).unwrap();
        assert!((back - Vec2::new(100.0, 70.0)).length() < 0.05, "{back}");
    }

    #[test]
    fn fit_puts_every_corner_of_the_box_in_view() {
        let bounds = (Vec3::new(-4.0, 0.0, -0.5), Vec3::new(4.0, 14.5, 0.5));
        for aspect in [0.5, 1.0, 2.0] {
            let cam = OrbitCamera::from_hint(&CameraHint::default(), bounds, aspect);
            let size = Vec2::new(100.0 * aspect, 100.0);
            for i in 0..8 {
                let corner = Vec3::new(
                    if i & 1 == 0 { bounds.0.x } else { bounds.1.x },
                    if i & 2 == 0 { bounds.0.y } else { bounds.1.y },
                    if i & 4 == 0 { bounds.0.z } else { bounds.1.z },
                );
                let (p, _) = cam.project(corner, size, 20.0).unwrap();
                assert!(p.x >= 0.0 && p.x <= size.x && p.y >= 0.0 && p.y <= size.y, "{corner} → {p} ({aspect})");
            }
        }
    }

    #[test]
    fn keep_above_lifts_an_eye_below_the_ground_and_leaves_others() {
        let mut cam =
            OrbitCamera { target: Vec3::new(0.0, 0.5, 0.0), pitch: -0.5, distance: 4.0, ..Default::default() };
        assert!(cam.eye().y < 0.0);
        cam.keep_above(0.0);
        // 2 % of 4 m above the ground, to rounding.
        assert!((cam.eye().y - 0.08).abs() < 1e-4, "{}", cam.eye());
        let mut high = OrbitCamera { pitch: 0.3, ..cam };
        high.keep_above(0.0);
        assert_eq!(high.pitch, 0.3);
    }

    #[test]
    fn orbit_keeps_the_target_and_distance_and_clamps_pitch() {
        let mut cam = OrbitCamera::default();
        cam.orbit(Vec2::new(50.0, 1e5));
        assert!(close(cam.target, Vec3::ZERO));
        assert!((cam.eye().length() - cam.distance).abs() < 1e-4);
        assert!(cam.pitch <= MAX_PITCH);
    }

    #[test]
    fn pan_moves_the_target_so_the_drag_follows_the_cursor() {
        let mut cam = OrbitCamera::default();
        let size = Vec2::new(400.0, 300.0);
        let before = cam.project(Vec3::ZERO, size, 10.0).unwrap().0;
        cam.pan(Vec2::new(20.0, -10.0), size.y);
        let after = cam.project(Vec3::ZERO, size, 10.0).unwrap().0;
        // The world point under the cursor moved with the cursor.
        assert!((after - before - Vec2::new(20.0, -10.0)).length() < 0.5, "{before} → {after}");
    }

    #[test]
    fn ray_hits_a_triangle_and_a_plane() {
        let ray = Ray { origin: Vec3::new(0.2, 0.2, 5.0), direction: Vec3::NEG_Z };
        let t = ray.hit_triangle(Vec3::ZERO, Vec3::X, Vec3::Y).unwrap();
        assert!((t - 5.0).abs() < 1e-6);
        assert!(
            ray.hit_triangle(Vec3::new(1.0, 1.0, 0.0), Vec3::new(2.0, 1.0, 0.0), Vec3::new(1.0, 2.0, 0.0)).is_none()
        );
        let p = ray.hit_plane(Vec3::new(0.0, 0.0, 1.0), Vec3::Z).unwrap();
        assert!(close(p, Vec3::new(0.2, 0.2, 1.0)));
    }
}
