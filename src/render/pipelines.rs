//! The render pipelines: one per layer, all sharing the frame uniform.

use super::shaders;
use super::targets::DEPTH_FORMAT;

/// Every pipeline the renderer uses, and the uniform's bind group layout.
#[derive(Debug)]
pub(crate) struct Pipelines {
    pub frame_layout: wgpu::BindGroupLayout,
    pub sky: wgpu::RenderPipeline,
    pub ground: wgpu::RenderPipeline,
    pub shadow: wgpu::RenderPipeline,
    pub surface: wgpu::RenderPipeline,
    pub wireframe: wgpu::RenderPipeline,
    pub bars: wgpu::RenderPipeline,
    pub points: wgpu::RenderPipeline,
    pub colliders: wgpu::RenderPipeline,
    pub collider_shadow: wgpu::RenderPipeline,
}

const SURFACE_ATTRIBUTES: [wgpu::VertexAttribute; 2] = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];
const MATERIAL_ATTRIBUTES: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![2 => Float32x2];
const STRAIN_ATTRIBUTES: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![3 => Float32];
const BAR_ATTRIBUTES: [wgpu::VertexAttribute; 4] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32, 2 => Float32x3, 3 => Float32];
const POINT_ATTRIBUTES: [wgpu::VertexAttribute; 2] = wgpu::vertex_attr_array![0 => Float32x3, 1 => Uint32];

/// The surface's three vertex streams: positions and normals (rewritten
/// when the cloth moves), material coordinates (per scene), strain.
const SURFACE_BUFFERS: [Option<wgpu::VertexBufferLayout<'static>>; 3] = [
    Some(wgpu::VertexBufferLayout {
        array_stride: 24,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &SURFACE_ATTRIBUTES,
    }),
    Some(wgpu::VertexBufferLayout {
        array_stride: 8,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &MATERIAL_ATTRIBUTES,
    }),
    Some(wgpu::VertexBufferLayout {
        array_stride: 4,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &STRAIN_ATTRIBUTES,
    }),
];
/// Colliders: positions and normals, world space.
const COLLIDER_BUFFERS: [Option<wgpu::VertexBufferLayout<'static>>; 1] = [Some(wgpu::VertexBufferLayout {
    array_stride: 24,
    step_mode: wgpu::VertexStepMode::Vertex,
    attributes: &SURFACE_ATTRIBUTES,
})];
const BAR_BUFFERS: [Option<wgpu::VertexBufferLayout<'static>>; 1] = [Some(wgpu::VertexBufferLayout {
    array_stride: 32,
    step_mode: wgpu::VertexStepMode::Instance,
    attributes: &BAR_ATTRIBUTES,
})];
const POINT_BUFFERS: [Option<wgpu::VertexBufferLayout<'static>>; 1] = [Some(wgpu::VertexBufferLayout {
    array_stride: 16,
    step_mode: wgpu::VertexStepMode::Instance,
    attributes: &POINT_ATTRIBUTES,
})];

/// How a layer uses depth and stencil.
#[derive(Clone, Copy)]
enum Depth {
    /// Neither tests nor writes (the sky, drawn first).
    Ignore,
    /// Tests and writes: opaque geometry.
    Opaque,
    /// Tests without writing: lines over the surface.
    TestOnly,
    /// Tests, and draws each pixel once through the stencil: the shadow.
    StencilOnce,
}

impl Depth {
    fn state(self) -> wgpu::DepthStencilState {
        let (write, compare) = match self {
            Depth::Ignore => (false, wgpu::CompareFunction::Always),
            Depth::Opaque => (true, wgpu::CompareFunction::Less),
            Depth::TestOnly | Depth::StencilOnce => (false, wgpu::CompareFunction::LessEqual),
        };
        let stencil = match self {
            Depth::StencilOnce => {
                let face = wgpu::StencilFaceState {
                    compare: wgpu::CompareFunction::Equal,
                    fail_op: wgpu::StencilOperation::Keep,
                    depth_fail_op: wgpu::StencilOperation::Keep,
                    pass_op: wgpu::StencilOperation::IncrementClamp,
                };
                wgpu::StencilState { front: face, back: face, read_mask: 0xff, write_mask: 0xff }
            }
            _ => wgpu::StencilState::default(),
        };
        wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(write),
            depth_compare: Some(compare),
            stencil,
            bias: wgpu::DepthBiasState::default(),
        }
    }
}

/// One pipeline's description, filled in by [`Pipelines::new`].
struct Layer<'a> {
    label: &'static str,
    module: &'a wgpu::ShaderModule,
    vertex: &'static str,
    fragment: &'static str,
    buffers: &'a [Option<wgpu::VertexBufferLayout<'static>>],
    topology: wgpu::PrimitiveTopology,
    depth: Depth,
    /// Premultiplied alpha blending (the shadow); opaque otherwise.
    blend: bool,
}

impl Pipelines {
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat, samples: u32) -> Self {
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("frame"),
            bind_group_layouts: &[Some(&frame_layout)],
            immediate_size: 0,
        });
        let module = |file: shaders::ShaderFile| {
            device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(file.name),
                source: wgpu::ShaderSource::Wgsl(file.source().into()),
            })
        };
        let surface_module = module(shaders::SURFACE);
        let backdrop_module = module(shaders::BACKDROP);
        let lines_module = module(shaders::LINES);
        let points_module = module(shaders::POINTS);
        let colliders_module = module(shaders::COLLIDERS);

        let build = |layer: Layer<'_>| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(layer.label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: layer.module,
                    entry_point: Some(layer.vertex),
                    buffers: layer.buffers,
                    compilation_options: wgpu::PipelineCompilationOptions::default(),
                },
                primitive: wgpu::PrimitiveState {
                    topology: layer.topology,
                    strip_index_format: None,
                    front_face: wgpu::FrontFace::Ccw,
                    // Cloth has two sides: nothing is culled.
                    cull_mode: None,
                    unclipped_depth: false,
                    polygon_mode: wgpu::PolygonMode::Fill,
                    conservative: false,
                },
                depth_stencil: Some(layer.depth.state()),
                multisample: wgpu::MultisampleState { count: samples, mask: !0, alpha_to_coverage_enabled: false },
                fragment: Some(wgpu::FragmentState {
                    module: layer.module,
                    entry_point: Some(layer.fragment),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: layer.blend.then_some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                    compilation_options: wgpu::PipelineCompilationOptions::default(),
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        use wgpu::PrimitiveTopology as T;
        let sky = build(Layer {
            label: "sky",
            module: &backdrop_module,
            vertex: "vs_sky",
            fragment: "fs_sky",
            buffers: &[],
            topology: T::TriangleList,
            depth: Depth::Ignore,
            blend: false,
        });
        let ground = build(Layer {
            label: "ground",
            module: &backdrop_module,
            vertex: "vs_ground",
            fragment: "fs_ground",
            buffers: &[],
            topology: T::TriangleStrip,
            depth: Depth::Opaque,
            blend: false,
        });
        let shadow = build(Layer {
            label: "shadow",
            module: &surface_module,
            vertex: "vs_shadow",
            fragment: "fs_shadow",
            buffers: &SURFACE_BUFFERS,
            topology: T::TriangleList,
            depth: Depth::StencilOnce,
            blend: true,
        });
        let surface = build(Layer {
            label: "surface",
            module: &surface_module,
            vertex: "vs_surface",
            fragment: "fs_surface",
            buffers: &SURFACE_BUFFERS,
            topology: T::TriangleList,
            depth: Depth::Opaque,
            blend: false,
        });
        let wireframe = build(Layer {
            label: "wireframe",
            module: &surface_module,
            vertex: "vs_wireframe",
            fragment: "fs_wireframe",
            buffers: &SURFACE_BUFFERS,
            topology: T::LineList,
            depth: Depth::TestOnly,
            blend: false,
        });
        let bars = build(Layer {
            label: "bars",
            module: &lines_module,
            vertex: "vs_bar",
            fragment: "fs_bar",
            buffers: &BAR_BUFFERS,
            topology: T::TriangleList,
            depth: Depth::Opaque,
            blend: false,
        });
        let points = build(Layer {
            label: "points",
            module: &points_module,
            vertex: "vs_point",
            fragment: "fs_point",
            buffers: &POINT_BUFFERS,
            topology: T::TriangleList,
            depth: Depth::Opaque,
            blend: false,
        });
        let colliders = build(Layer {
            label: "colliders",
            module: &colliders_module,
            vertex: "vs_collider",
            fragment: "fs_collider",
            buffers: &COLLIDER_BUFFERS,
            topology: T::TriangleList,
            depth: Depth::Opaque,
            blend: false,
        });
        let collider_shadow = build(Layer {
            label: "collider shadow",
            module: &colliders_module,
            vertex: "vs_collider_shadow",
            fragment: "fs_collider_shadow",
            buffers: &COLLIDER_BUFFERS,
            topology: T::TriangleList,
            depth: Depth::StencilOnce,
            blend: true,
        });
        Self { frame_layout, sky, ground, shadow, surface, wireframe, bars, points, colliders, collider_shadow }
    }
}
