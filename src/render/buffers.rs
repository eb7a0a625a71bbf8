//! The GPU buffers behind a frame: the cloth's (index buffers and
//! material coordinates uploaded once a mesh; surface vertices, strain and
//! instances rebuilt from the positions only for the layers a frame shows
//! and only when stale) and the colliders' (rebuilt when they move), in
//! buffers that grow as needed.

use std::sync::Arc;

use glam::Vec3;

use super::geometry::{self, BarInstance, MeshLayout, PointInstance, SurfaceVertex};
use super::view::ViewOptions;
use crate::sim::ClothMesh;

/// The colliders' triangles, world space, rebuilt when they move.
#[derive(Debug)]
pub(super) struct ColliderBuffers {
    pub(super) vertices: GrowingBuffer,
    pub(super) indices: GrowingBuffer,
    pub(super) index_count: u32,
    /// The height of a horizontal plane collider facing up: the ground.
    pub(super) ground: Option<f32>,
    pub(super) scratch_vertices: Vec<geometry::SurfaceVertex>,
    pub(super) scratch_indices: Vec<u32>,
}

/// A vertex or instance buffer that grows as needed.
#[derive(Debug)]
pub(super) struct GrowingBuffer {
    pub(super) label: &'static str,
    pub(super) buffer: wgpu::Buffer,
}

impl GrowingBuffer {
    pub(super) fn new(device: &wgpu::Device, label: &'static str, size: u64) -> Self {
        Self::with_usage(device, label, size, wgpu::BufferUsages::VERTEX)
    }

    pub(super) fn with_usage(device: &wgpu::Device, label: &'static str, size: u64, usage: wgpu::BufferUsages) -> Self {
        Self { label, buffer: vertex_buffer(device, label, size, usage) }
    }

    pub(super) fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        if (bytes.len() as u64) > self.buffer.size() {
            let usage = self.buffer.usage() - wgpu::BufferUsages::COPY_DST;
            self.buffer = vertex_buffer(device, self.label, (bytes.len() as u64).next_power_of_two(), usage);
        }
        queue.write_buffer(&self.buffer, 0, bytes);
    }
}

/// An empty buffer of at least `size` bytes (16 at least, a multiple of
/// wgpu's copy alignment) that can be written to.
fn vertex_buffer(device: &wgpu::Device, label: &'static str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT),
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A buffer holding `bytes`.
fn init_buffer(device: &wgpu::Device, label: &str, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
    use wgpu::util::DeviceExt as _;
    // Never empty: a zero-sized buffer cannot be bound.
    let padded;
    let contents = if bytes.is_empty() {
        padded = [0u8; 16];
        &padded[..]
    } else {
        bytes
    };
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
}

/// Which derived data is out of date with respect to the last positions.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Stale {
    pub(super) surface: bool,
    pub(super) strain: bool,
    pub(super) bars: bool,
    pub(super) points: bool,
}

impl Stale {
    pub(super) fn all() -> Self {
        Self { surface: true, strain: true, bars: true, points: true }
    }
}

/// The GPU buffers and CPU state of the cloth being drawn.
#[derive(Debug)]
pub(super) struct ClothBuffers {
    pub(super) mesh: Arc<ClothMesh>,
    pub(super) layout: MeshLayout,
    pub(super) material: wgpu::Buffer,
    pub(super) triangles: wgpu::Buffer,
    pub(super) triangle_indices: u32,
    pub(super) edges: wgpu::Buffer,
    pub(super) edge_indices: u32,
    pub(super) surface: GrowingBuffer,
    pub(super) strain: GrowingBuffer,
    pub(super) bars: GrowingBuffer,
    pub(super) bar_count: u32,
    pub(super) bars_built_for: (bool, bool),
    pub(super) points: GrowingBuffer,
    pub(super) point_count: u32,
    pub(super) points_built_for: (bool, bool),
    pub(super) positions: Vec<Vec3>,
    pub(super) fixed: Vec<bool>,
    pub(super) highlight: Option<usize>,
    pub(super) stale: Stale,
    // Scratch space reused every frame.
    pub(super) normals: Vec<Vec3>,
    pub(super) surface_vertices: Vec<SurfaceVertex>,
    pub(super) vertex_strain: Vec<f32>,
    pub(super) bar_instances: Vec<BarInstance>,
    pub(super) point_instances: Vec<PointInstance>,
}

impl ClothBuffers {
    pub(super) fn new(device: &wgpu::Device, mesh: Arc<ClothMesh>) -> Self {
        let layout = MeshLayout::new(&mesh);
        let index = wgpu::BufferUsages::INDEX;
        let n = mesh.particle_count() as u64;
        let triangles = init_buffer(device, "triangles", bytemuck::cast_slice(mesh.triangles()), index);
        let edges = init_buffer(device, "wireframe edges", bytemuck::cast_slice(&layout.edges), index);
        let material = init_buffer(device, "material coordinates", bytemuck::cast_slice(&layout.material), {
            wgpu::BufferUsages::VERTEX
        });
        Self {
            triangle_indices: (mesh.triangles().len() * 3) as u32,
            edge_indices: (layout.edges.len() * 2) as u32,
            triangles,
            edges,
            material,
            surface: GrowingBuffer::new(device, "surface vertices", n * size_of::<SurfaceVertex>() as u64),
            strain: GrowingBuffer::new(device, "vertex strain", n * 4),
            bars: GrowingBuffer::new(device, "bar instances", 16),
            bar_count: 0,
            bars_built_for: (false, false),
            points: GrowingBuffer::new(device, "point instances", 16),
            point_count: 0,
            points_built_for: (false, false),
            positions: mesh.positions().to_vec(),
            fixed: mesh.fixed().to_vec(),
            highlight: None,
            stale: Stale::all(),
            normals: Vec::new(),
            surface_vertices: Vec::new(),
            vertex_strain: Vec::new(),
            bar_instances: Vec::new(),
            point_instances: Vec::new(),
            layout,
            mesh,
        }
    }

    /// Rebuilds and uploads what `options` shows and is out of date.
    pub(super) fn prepare(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, options: &ViewOptions) {
        let has_surface = self.triangle_indices > 0;
        if options.surface && has_surface && self.stale.surface {
            geometry::vertex_normals(&self.positions, self.mesh.triangles(), &mut self.normals);
            geometry::surface_vertices(&self.positions, &self.normals, &mut self.surface_vertices);
            self.surface.write(device, queue, bytemuck::cast_slice(&self.surface_vertices));
            self.stale.surface = false;
        }
        if options.surface && has_surface && options.strain_colours && self.stale.strain {
            let mesh = &self.mesh;
            geometry::vertex_strain(&self.positions, mesh.bars(), |b| mesh.is_edge(b), &mut self.vertex_strain);
            self.strain.write(device, queue, bytemuck::cast_slice(&self.vertex_strain));
            self.stale.strain = false;
        }
        let bars_key = (options.structural_bars, options.bend_bars);
        if (bars_key.0 || bars_key.1) && (self.stale.bars || self.bars_built_for != bars_key) {
            let bars = self.mesh.bars();
            geometry::bar_instances(&self.positions, bars, bars_key.0, bars_key.1, &mut self.bar_instances);
            self.bars.write(device, queue, bytemuck::cast_slice(&self.bar_instances));
            self.bar_count = self.bar_instances.len() as u32;
            self.bars_built_for = bars_key;
            self.stale.bars = false;
        }
        let points_key = (options.particles, options.pins);
        if self.stale.points || self.points_built_for != points_key {
            geometry::point_instances(
                &self.positions,
                &self.fixed,
                options.particles,
                options.pins,
                self.highlight,
                &mut self.point_instances,
            );
            self.points.write(device, queue, bytemuck::cast_slice(&self.point_instances));
            self.point_count = self.point_instances.len() as u32;
            self.points_built_for = points_key;
            self.stale.points = false;
        }
    }
}
