//! [`Renderer`]: draws a cloth into any texture view — the window's surface
//! or an offscreen texture — with the same code.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::buffers::{ClothBuffers, ColliderBuffers, GrowingBuffer, Stale};
use super::camera::OrbitCamera;
use super::colliders;
use super::geometry::{self, MeshLayout};
use super::gpu::Gpu;
use super::pipelines::Pipelines;
use super::targets::{self, FrameTargets};
use super::view::{ViewOptions, strain_ramp_linear};
use crate::sim::{ClothMesh, Simulation};

/// Direction towards the key light, world space (before normalising): high,
/// and from the side the scenes' cameras look from, so the shadow falls
/// behind the cloth.
const LIGHT_DIRECTION: Vec3 = Vec3::new(0.45, 1.0, 0.55);
/// The colour outside the viewport (sRGB bytes; only seen if nothing covers it).
const CLEAR_SRGB: [u8; 3] = [0x30, 0x33, 0x38];

/// A rectangle of the target, in pixels from the top-left corner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Viewport {
    /// Left edge.
    pub x: f32,
    /// Top edge.
    pub y: f32,
    /// Width, > 0.
    pub width: f32,
    /// Height, > 0.
    pub height: f32,
}

impl Viewport {
    /// The whole of a `width × height` target.
    pub fn full(width: u32, height: u32) -> Self {
        Self { x: 0.0, y: 0.0, width: width.max(1) as f32, height: height.max(1) as f32 }
    }

    /// Width over height.
    pub fn aspect(&self) -> f32 {
        self.width / self.height.max(1.0)
    }

    /// Whether a point (pixels, target coordinates) lies inside.
    pub fn contains(&self, p: glam::Vec2) -> bool {
        p.x >= self.x && p.y >= self.y && p.x < self.x + self.width && p.y < self.y + self.height
    }
}

/// Everything about one frame that is not the cloth itself.
#[derive(Clone, Copy, Debug)]
pub struct FrameSpec {
    /// The camera.
    pub camera: OrbitCamera,
    /// Where in the target to draw the 3-D view.
    pub viewport: Viewport,
    /// Which layers, and how.
    pub options: ViewOptions,
    /// Physical pixels per logical point (the window's scale factor): bar
    /// widths and dot sizes are in points.
    pub pixels_per_point: f32,
}

/// The uniform block `common.wgsl` declares as `Frame`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct FrameUniform {
    view_proj: [[f32; 4]; 4],
    inv_view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    light_dir: [f32; 4],
    viewport: [f32; 4],
    ground: [f32; 4],
    centre: [f32; 4],
    style: [f32; 4],
    ramp: [[f32; 4]; 5],
}

/// Draws a cloth, its ground and its backdrop into texture views.
///
/// Per-scene data (index buffers, material coordinates) is uploaded once by
/// [`Renderer::set_mesh`]; positions are copied by [`Renderer::update`],
/// which the caller invokes only when the simulation changed; what is
/// derived from them (normals, strain, instances) is rebuilt and uploaded
/// only for the layers a frame shows.
#[derive(Debug)]
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    format: wgpu::TextureFormat,
    samples: u32,
    uniform: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    pipelines: Pipelines,
    targets: Option<FrameTargets>,
    cloth: Option<ClothBuffers>,
    colliders: ColliderBuffers,
}

impl Renderer {
    /// A renderer for targets of `format`, with 4× MSAA when the adapter
    /// supports it.
    pub fn new(gpu: &Gpu, format: wgpu::TextureFormat) -> Self {
        Self::with_samples(gpu, format, targets::msaa_samples(&gpu.adapter, format))
    }

    /// A renderer with `samples` per pixel (1 or a count the adapter supports).
    pub fn with_samples(gpu: &Gpu, format: wgpu::TextureFormat, samples: u32) -> Self {
        let device = gpu.device.clone();
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniform"),
            size: size_of::<FrameUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pipelines = Pipelines::new(&device, format, samples);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &pipelines.frame_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() }],
        });
        Self {
            device,
            queue: gpu.queue.clone(),
            format,
            samples,
            uniform,
            bind_group,
            pipelines,
            targets: None,
            cloth: None,
            colliders: ColliderBuffers {
                vertices: GrowingBuffer::new(&gpu.device, "collider vertices", 16),
                indices: GrowingBuffer::with_usage(&gpu.device, "collider indices", 16, wgpu::BufferUsages::INDEX),
                index_count: 0,
                ground: None,
                scratch_vertices: Vec::new(),
                scratch_indices: Vec::new(),
            },
        }
    }

    /// The colour format of the targets it draws into.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// Samples per pixel (1 without MSAA).
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Switches to another mesh: builds its index buffers and static data.
    /// Does nothing if `mesh` is the one already drawn.
    pub fn set_mesh(&mut self, mesh: &Arc<ClothMesh>) {
        if self.cloth.as_ref().is_some_and(|c| Arc::ptr_eq(&c.mesh, mesh)) {
            return;
        }
        self.cloth = Some(ClothBuffers::new(&self.device, mesh.clone()));
    }

    /// The per-scene layout (ground, checker, depth range) of the mesh drawn.
    pub fn layout(&self) -> Option<&MeshLayout> {
        self.cloth.as_ref().map(|c| &c.layout)
    }

    /// Takes the simulation's current positions and pins. Call it when they
    /// changed (a step, a drag, a reset), not every frame.
    pub fn update(&mut self, sim: &Simulation) {
        self.set_mesh(sim.mesh());
        if let Some(cloth) = &mut self.cloth {
            cloth.positions.clear();
            cloth.positions.extend_from_slice(sim.positions());
            cloth.fixed.clear();
            cloth.fixed.extend_from_slice(sim.fixed());
            cloth.stale = Stale::all();
        }
        self.set_colliders(sim.colliders(), &sim.collider_poses());
    }

    /// Takes the colliders at their poses: a horizontal plane facing up
    /// becomes the ground; everything else is tessellated and uploaded.
    pub fn set_colliders(&mut self, colliders: &[crate::sim::Collider], poses: &[crate::sim::Pose]) {
        let radius = self.layout().map_or(10.0, |l| l.ground.radius);
        let c = &mut self.colliders;
        c.ground = None;
        c.scratch_vertices.clear();
        c.scratch_indices.clear();
        for (collider, pose) in colliders.iter().zip(poses) {
            match colliders::ground_height(collider, pose) {
                Some(h) if c.ground.is_none() => c.ground = Some(h),
                _ => colliders::tessellate(collider, pose, radius, &mut c.scratch_vertices, &mut c.scratch_indices),
            }
        }
        c.vertices.write(&self.device, &self.queue, bytemuck::cast_slice(&c.scratch_vertices));
        c.indices.write(&self.device, &self.queue, bytemuck::cast_slice(&c.scratch_indices));
        c.index_count = c.scratch_indices.len() as u32;
    }

    /// The height of the ground plane collider, if the scene has one.
    pub fn ground_plane(&self) -> Option<f32> {
        self.colliders.ground
    }

    /// Marks one particle (the one held or under the mouse), or none.
    pub fn set_highlight(&mut self, particle: Option<usize>) {
        if let Some(cloth) = &mut self.cloth
            && cloth.highlight != particle
        {
            cloth.highlight = particle;
            cloth.stale.points = true;
        }
    }

    /// The radius that the camera's depth range must cover.
    pub fn world_radius(&self) -> f32 {
        self.layout().map_or(100.0, |l| l.world_radius)
    }

    /// Records the drawing of one frame into `target` (a view of a texture
    /// of `target_size` pixels in [`Self::format`]): the backdrop, then the
    /// layers `frame.options` asks for, inside `frame.viewport`.
    pub fn render(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        target_size: (u32, u32),
        frame: &FrameSpec,
    ) {
        if self.targets.as_ref().is_none_or(|t| t.size != target_size) {
            self.targets = Some(FrameTargets::new(&self.device, self.format, self.samples, target_size));
        }
        let options = frame.options;
        if let Some(cloth) = &mut self.cloth {
            cloth.prepare(&self.device, &self.queue, &options);
        }
        let viewport = clamp_viewport(frame.viewport, target_size);
        let uniform = self.frame_uniform(frame, viewport);
        self.queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));

        let Some(targets) = &self.targets else { return };
        let clear = if self.format.is_srgb() {
            CLEAR_SRGB.map(|c| f64::from(super::view::srgb_to_linear(c)))
        } else {
            CLEAR_SRGB.map(|c| f64::from(c) / 255.0)
        };
        let (view, resolve_target) = match &targets.msaa {
            Some(msaa) => (msaa, Some(target)),
            None => (target, None),
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("cloth"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                resolve_target,
                depth_slice: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r: clear[0], g: clear[1], b: clear[2], a: 1.0 }),
                    store: if resolve_target.is_some() { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store },
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                stencil_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0), store: wgpu::StoreOp::Discard }),
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let vp = viewport;
        pass.set_viewport(vp.x, vp.y, vp.width, vp.height, 0.0, 1.0);
        pass.set_scissor_rect(vp.x as u32, vp.y as u32, vp.width as u32, vp.height as u32);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_stencil_reference(0);

        let p = &self.pipelines;
        pass.set_pipeline(&p.sky);
        pass.draw(0..3, 0..1);
        if options.ground {
            pass.set_pipeline(&p.ground);
            pass.draw(0..4, 0..1);
        }
        let colliders = &self.colliders;
        let draw_colliders = options.colliders && colliders.index_count > 0;
        if draw_colliders {
            pass.set_vertex_buffer(0, colliders.vertices.buffer.slice(..));
            pass.set_index_buffer(colliders.indices.buffer.slice(..), wgpu::IndexFormat::Uint32);
            if options.ground {
                pass.set_pipeline(&p.collider_shadow);
                pass.draw_indexed(0..colliders.index_count, 0, 0..1);
            }
            pass.set_pipeline(&p.colliders);
            pass.draw_indexed(0..colliders.index_count, 0, 0..1);
        }
        let Some(cloth) = &self.cloth else { return };
        if options.surface && cloth.triangle_indices > 0 {
            pass.set_vertex_buffer(0, cloth.surface.buffer.slice(..));
            pass.set_vertex_buffer(1, cloth.material.slice(..));
            pass.set_vertex_buffer(2, cloth.strain.buffer.slice(..));
            pass.set_index_buffer(cloth.triangles.slice(..), wgpu::IndexFormat::Uint32);
            if options.ground {
                pass.set_pipeline(&p.shadow);
                pass.draw_indexed(0..cloth.triangle_indices, 0, 0..1);
            }
            pass.set_pipeline(&p.surface);
            pass.draw_indexed(0..cloth.triangle_indices, 0, 0..1);
            if options.wireframe && cloth.edge_indices > 0 {
                pass.set_pipeline(&p.wireframe);
                pass.set_index_buffer(cloth.edges.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..cloth.edge_indices, 0, 0..1);
            }
        }
        if (options.structural_bars || options.bend_bars) && cloth.bar_count > 0 {
            pass.set_pipeline(&p.bars);
            pass.set_vertex_buffer(0, cloth.bars.buffer.slice(..));
            pass.draw(0..6, 0..cloth.bar_count);
        }
        if cloth.point_count > 0 {
            pass.set_pipeline(&p.points);
            pass.set_vertex_buffer(0, cloth.points.buffer.slice(..));
            pass.draw(0..6, 0..cloth.point_count);
        }
    }

    fn frame_uniform(&self, frame: &FrameSpec, viewport: Viewport) -> FrameUniform {
        let world_radius = self.world_radius();
        let view_proj = frame.camera.view_projection(viewport.aspect(), world_radius);
        let inverse = view_proj.inverse();
        let options = &frame.options;
        let (mut ground, cell) = match self.layout() {
            Some(l) => (l.ground, l.checker_cell),
            None => (geometry::Ground { height: 0.0, centre: glam::Vec2::ZERO, major_spacing: 1.0, radius: 30.0 }, 1.0),
        };
        if let Some(height) = self.colliders.ground {
            // A real ground: drawn where the collider is.
            ground.height = height;
        }
        let ppp = frame.pixels_per_point.max(0.25);
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        FrameUniform {
            view_proj: view_proj.to_cols_array_2d(),
            inv_view_proj: inverse.to_cols_array_2d(),
            eye: frame.camera.eye().extend(1.0).to_array(),
            light_dir: LIGHT_DIRECTION.normalize().extend(0.0).to_array(),
            viewport: [viewport.width, viewport.height, flag(!self.format.is_srgb()), ppp],
            ground: [ground.height, ground.major_spacing, ground.radius, cell],
            centre: [ground.centre.x, ground.radius * 2e-4, ground.centre.y, 0.0],
            style: [
                options.strain_scale.max(1e-6),
                flag(options.strain_colours),
                options.bar_width * ppp,
                options.particle_radius * ppp,
            ],
            ramp: strain_ramp_linear(),
        }
    }
}

/// The part of `viewport` inside the target, at least one pixel.
fn clamp_viewport(viewport: Viewport, (width, height): (u32, u32)) -> Viewport {
    let (w, h) = (width.max(1) as f32, height.max(1) as f32);
    let x = viewport.x.clamp(0.0, w - 1.0).floor();
    let y = viewport.y.clamp(0.0, h - 1.0).floor();
    Viewport {
        x,
        y,
        width: viewport.width.clamp(1.0, w - x).floor(),
        height: viewport.height.clamp(1.0, h - y).floor(),
    }
}

// mat4 × 2 + vec4 × 6 + vec4 × 5: the size WGSL gives `Frame`.
const _: () = assert!(size_of::<FrameUniform>() == 128 + 96 + 80);
