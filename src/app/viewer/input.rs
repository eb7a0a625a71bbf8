//! The viewer's input: keys, and the mouse in the 3-D view (orbit, pan,
//! zoom, grab and pin particles, move colliders).

use egui::{Key, Modifiers, PointerButton, Ui};
use glam::{Vec2, Vec3};

use super::Viewer;
use crate::app::grab::{Grab, ViewGeometry, pick};
use crate::ui::UiCommand;

/// What a mouse drag in the 3-D view is doing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Drag {
    None,
    Orbit,
    Pan,
    Grab(Grab),
    /// Shift+drag on a collider: it follows the cursor in the plane facing
    /// the camera through the point first hit.
    Collider {
        index: usize,
        anchor: Vec3,
        normal: Vec3,
        start: crate::sim::Pose,
    },
}

/// Points of wheel scroll per 10 % zoom step.
const SCROLL_PER_ZOOM_STEP: f32 = 50.0;

impl Viewer {
    /// The key bindings, unless a text field has the keyboard. Keys are
    /// consumed before any widget sees them, so Space never also "clicks"
    /// a focused button.
    pub(super) fn keyboard(&mut self, ctx: &egui::Context) -> Vec<UiCommand> {
        if ctx.egui_wants_keyboard_input() {
            return Vec::new();
        }
        let bindings = [
            (Key::Space, UiCommand::TogglePause),
            (Key::S, UiCommand::Step),
            (Key::R, UiCommand::Reset),
            (Key::F, UiCommand::FitCamera),
            (Key::Home, UiCommand::ResetCamera),
            (Key::F12, UiCommand::Screenshot),
            (Key::Escape, UiCommand::Quit),
        ];
        let last = self.timeline.recording().len().saturating_sub(1);
        let shown = self.timeline.cursor().unwrap_or(last);
        let playing = self.timeline.playing();
        ctx.input_mut(|input| {
            let mut commands: Vec<UiCommand> = bindings
                .into_iter()
                .chain([(Key::P, UiCommand::PlayRecording(!playing))])
                .filter(|(key, _)| input.consume_key(Modifiers::NONE, *key))
                .map(|(_, c)| c)
                .collect();
            // Every press of an arrow counts, however many arrive in a frame.
            let back = input.count_and_consume_key(Modifiers::NONE, Key::ArrowLeft);
            let on = input.count_and_consume_key(Modifiers::NONE, Key::ArrowRight);
            if back + on > 0 {
                commands.push(UiCommand::ScrubTo((shown + on).saturating_sub(back).min(last)));
            }
            commands
        })
    }

    /// The 3-D view: orbit, pan, zoom, grab and pin with the mouse.
    pub(super) fn view_area(&mut self, ui: &mut Ui) {
        let rect = ui.max_rect();
        self.view_rect = rect;
        self.pixels_per_point = ui.ctx().pixels_per_point();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        let (pointer, modifiers, scroll) = ui.input(|i| (i.pointer.clone(), i.modifiers, i.smooth_scroll_delta()));
        let ppp = self.pixels_per_point;
        // Cursor in viewport pixels.
        let cursor = pointer.interact_pos().map(|p| Vec2::new(p.x - rect.left(), p.y - rect.top()) * ppp);

        if response.hovered() && scroll.y != 0.0 {
            self.camera.zoom(scroll.y / SCROLL_PER_ZOOM_STEP);
        }
        // The particle under the cursor, picked once a frame: highlighted
        // before a click, and the one a click takes.
        let under = match (&self.drag, cursor) {
            (Drag::None, Some(cursor)) if response.hovered() => {
                pick(self.sim.positions(), self.sim.mesh().triangles(), &self.view_geometry(), cursor)
            }
            _ => None,
        };
        if matches!(self.drag, Drag::None) {
            // Shift drags colliders: no particle is highlighted then.
            self.hovered = under.filter(|_| !modifiers.shift);
            self.renderer.set_highlight(self.hovered);
        }
        if response.hovered()
            && pointer.primary_pressed()
            && let Some(cursor) = cursor
        {
            let geometry = self.view_geometry();
            // Picked above unless a drag (a pan) is under way.
            let picked = match self.drag {
                Drag::None => under,
                _ => pick(self.sim.positions(), self.sim.mesh().triangles(), &geometry, cursor),
            };
            let collider = modifiers.shift.then(|| self.pick_collider(&geometry, cursor)).flatten();
            match picked {
                _ if collider.is_some() => {
                    if let Some((index, anchor, start)) = collider {
                        let ray = geometry.camera.ray(cursor, geometry.size, geometry.world_radius);
                        self.drag = Drag::Collider { index, anchor, normal: -ray.direction, start };
                    }
                }
                Some(i) if modifiers.ctrl || modifiers.command => self.toggle_pin(i),
                Some(i) => match Grab::start(&mut self.sim, i, &geometry, cursor) {
                    Ok(grab) => {
                        self.drag = Drag::Grab(grab);
                        self.renderer.set_highlight(Some(i));
                        self.touched();
                    }
                    Err(e) => self.toast(e.to_string(), true),
                },
                None if modifiers.ctrl || modifiers.command => {}
                None => self.drag = Drag::Orbit,
            }
        }
        if response.hovered()
            && matches!(self.drag, Drag::None)
            && (pointer.button_pressed(PointerButton::Secondary) || pointer.button_pressed(PointerButton::Middle))
        {
            self.drag = Drag::Pan;
        }
        let delta = Vec2::new(pointer.delta().x, pointer.delta().y) * ppp;
        let geometry = self.view_geometry();
        match &mut self.drag {
            Drag::Orbit => self.camera.orbit(delta),
            Drag::Pan => self.camera.pan(delta, geometry.size.y),
            Drag::Grab(grab) => {
                if let Some(cursor) = cursor {
                    grab.drag_to(&geometry, cursor);
                }
            }
            Drag::Collider { index, anchor, normal, start } => {
                let ray = cursor.map(|c| geometry.camera.ray(c, geometry.size, geometry.world_radius));
                let denominator = ray.map_or(0.0, |r| r.direction.dot(*normal));
                if let Some(ray) = ray
                    && denominator.abs() > 1e-6
                {
                    let t = (*anchor - ray.origin).dot(*normal) / denominator;
                    let to = ray.origin + ray.direction * t;
                    let pose = crate::sim::Pose { translation: start.translation + (to - *anchor), ..*start };
                    let index = *index;
                    if let Err(e) = self.sim.move_collider(index, pose) {
                        self.toast(e.to_string(), true);
                    }
                    self.touched();
                }
            }
            Drag::None => {}
        }
        if let Some(ground) = self.renderer.ground_plane() {
            self.camera.keep_above(ground);
        }
        let released = match self.drag {
            Drag::Orbit | Drag::Grab(_) | Drag::Collider { .. } => {
                !pointer.primary_down() || pointer.primary_released()
            }
            Drag::Pan => !pointer.secondary_down() && !pointer.middle_down(),
            Drag::None => false,
        };
        if released {
            self.end_drag();
        }
        if let Drag::Grab(_) = self.drag {
            ui.ctx().set_cursor_icon(egui::CursorIcon::Grabbing);
        }
    }

    /// The collider (other than a plane) under the cursor: its index, the
    /// point hit and its pose now.
    fn pick_collider(&self, view: &ViewGeometry, cursor: Vec2) -> Option<(usize, Vec3, crate::sim::Pose)> {
        let ray = view.camera.ray(cursor, view.size, view.world_radius);
        let far = ray.origin + ray.direction * (4.0 * view.world_radius + view.camera.distance);
        let poses = self.sim.collider_poses();
        let mut best: Option<(f32, usize, Vec3, crate::sim::Pose)> = None;
        for (k, (c, pose)) in self.sim.colliders().iter().zip(poses).enumerate() {
            if matches!(c.shape, crate::sim::Shape::Plane { .. }) {
                continue;
            }
            let (from, to) = (pose.inverse_apply(ray.origin), pose.inverse_apply(far));
            if let Some(entry) = c.shape.entry(from, to) {
                let hit = pose.apply(entry.point);
                let d = hit.distance(ray.origin);
                if best.is_none_or(|b| d < b.0) {
                    best = Some((d, k, hit, pose));
                }
            }
        }
        best.map(|(_, k, hit, pose)| (k, hit, pose))
    }

    pub(super) fn end_drag(&mut self) {
        if let Drag::Grab(grab) = std::mem::replace(&mut self.drag, Drag::None) {
            // Put it where the mouse last was, so the release carries the
            // last move's velocity, then give it back its fixedness.
            let result = grab.hold(&mut self.sim).and_then(|()| grab.release(&mut self.sim));
            if let Err(e) = result {
                self.toast(e.to_string(), true);
            }
            self.renderer.set_highlight(None);
            self.touched();
        }
    }

    fn toggle_pin(&mut self, particle: usize) {
        let fixed = self.sim.fixed().get(particle).copied().unwrap_or(false);
        match self.sim.set_fixed(particle, !fixed) {
            Ok(()) => {
                self.touched();
                let what = if fixed { "unpinned" } else { "pinned" };
                self.toast(format!("particle {particle} {what}"), false);
            }
            Err(e) => self.toast(e.to_string(), true),
        }
    }
}
