//! Binary glTF 2.0 (.glb): the cloth's surface and its motion in one file.
//!
//! The file holds one mesh node, "cloth", whose single triangle primitive
//! has the first recorded frame's positions and normals, texture
//! coordinates from the rest shape ([`texture_coordinates`]), u32 indices
//! and a double-sided material. Its motion is a morph-target animation, the
//! usual form of a cloth cache (Blender imports the targets as shape keys,
//! three.js as morph attributes):
//!
//! - target k holds frame k's displacements from the base,
//!   Δx_k = x_k − x_0 and Δn_k = n_k − n_0;
//! - the animation "simulation" keys the mesh's weights at each frame's
//!   time t_k − t_0 (seconds) to the unit vector e_k, interpolated
//!   linearly, so that at t_k the surface is x_0 + Δx_k = x_k and between
//!   frames it blends the two neighbours.
//!
//! The weight keys are dense (F² floats for F frames): they outweigh the
//! targets (24 bytes per particle per frame) only past about six frames
//! per particle, which a cloth cache does not reach. Everything is
//! little-endian f32/u32 in one binary chunk; a .glb can address 4 GiB.

use std::collections::BTreeMap;
use std::path::Path;

use glam::Vec3;
use gltf::json;
use json::validation::Checked::Valid;
use json::validation::USize64;

use super::{ExportError, Recording, create_parent};
use crate::sim::mesh::surface::{texture_coordinates, vertex_normals};

/// Writes `recording` as a .glb file at `path` (its directory created if
/// needed).
pub fn write_file(path: &Path, recording: &Recording) -> Result<(), ExportError> {
    let bytes = to_bytes(recording)?;
    create_parent(path)?;
    std::fs::write(path, bytes).map_err(ExportError::io(path))
}

/// The .glb file's bytes.
pub fn to_bytes(recording: &Recording) -> Result<Vec<u8>, ExportError> {
    let mesh = recording.mesh();
    let triangles = mesh.triangles();
    if triangles.is_empty() {
        return Err(ExportError::NoTriangles);
    }
    let frames = recording.frames();
    let first = frames.front().ok_or(ExportError::Empty)?;
    let n = mesh.particle_count();
    if let Some(f) = frames.iter().find(|f| f.positions.len() != n) {
        return Err(ExportError::FrameSize { expected: n, got: f.positions.len() });
    }
    // Binary chunk size, checked before anything is allocated: base
    // (positions, normals: 24 B, uv: 8 B per particle), indices, two
    // displacement arrays per frame, times and weights.
    let count = frames.len() as u64;
    let bytes = 32 * n as u64 + 12 * triangles.len() as u64 + count * 24 * n as u64 + 4 * count + 4 * count * count;
    if bytes > u64::from(u32::MAX) - (1 << 20) {
        return Err(ExportError::TooLarge { bytes });
    }

    let mut doc = Document::default();
    let base = &first.positions;
    let mut base_normals = Vec::new();
    vertex_normals(base, triangles, &mut base_normals);

    let position = doc.vec3s(base, json::buffer::Target::ArrayBuffer, true);
    let normal = doc.vec3s(&base_normals, json::buffer::Target::ArrayBuffer, false);
    let uvs: Vec<f32> = texture_coordinates(mesh).iter().flat_map(|uv| uv.to_array()).collect();
    let texcoord = doc.accessor(&uvs, Some(json::buffer::Target::ArrayBuffer), json::accessor::Type::Vec2, None);
    let flat: Vec<u32> = triangles.iter().flatten().copied().collect();
    let indices = doc.indices(&flat);

    let mut normals = Vec::new();
    let mut targets = Vec::with_capacity(frames.len());
    for frame in frames {
        vertex_normals(&frame.positions, triangles, &mut normals);
        let dx: Vec<Vec3> = frame.positions.iter().zip(base).map(|(p, b)| *p - *b).collect();
        let dn: Vec<Vec3> = normals.iter().zip(&base_normals).map(|(p, b)| *p - *b).collect();
        targets.push(json::mesh::MorphTarget {
            positions: Some(doc.vec3s(&dx, json::buffer::Target::ArrayBuffer, true)),
            normals: Some(doc.vec3s(&dn, json::buffer::Target::ArrayBuffer, false)),
            tangents: None,
        });
    }

    let times: Vec<f32> = frames.iter().map(|f| (f.time - first.time) as f32).collect();
    let time_range = (json::Value::from(vec![times[0]]), json::Value::from(vec![*times.last().unwrap_or(&0.0)]));
    let input = doc.accessor(&times, None, json::accessor::Type::Scalar, Some(time_range));
    let frame_count = frames.len();
    let mut weights = vec![0f32; frame_count * frame_count];
    for k in 0..frame_count {
        weights[k * frame_count + k] = 1.0;
    }
    let output = doc.accessor(&weights, None, json::accessor::Type::Scalar, None);

    let root = &mut doc.root;
    let material = root.push(json::Material {
        double_sided: true,
        name: Some("cloth".into()),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor([0.8, 0.35, 0.3, 1.0]),
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(0.9),
            ..Default::default()
        },
        ..Default::default()
    });
    let mut initial = vec![0.0; frame_count];
    initial[0] = 1.0;
    let mesh_index = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: Some("cloth".into()),
        primitives: vec![json::mesh::Primitive {
            attributes: BTreeMap::from([
                (Valid(json::mesh::Semantic::Positions), position),
                (Valid(json::mesh::Semantic::Normals), normal),
                (Valid(json::mesh::Semantic::TexCoords(0)), texcoord),
            ]),
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: Some(material),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: Some(targets),
        }],
        weights: Some(initial),
    });
    let node = root.push(json::Node { mesh: Some(mesh_index), name: Some("cloth".into()), ..Default::default() });
    let scene = root.push(json::Scene { extensions: None, extras: Default::default(), name: None, nodes: vec![node] });
    root.scene = Some(scene);
    let sampler = json::animation::Sampler {
        extensions: None,
        extras: Default::default(),
        input,
        interpolation: Valid(json::animation::Interpolation::Linear),
        output,
    };
    root.push(json::Animation {
        extensions: None,
        extras: Default::default(),
        channels: vec![json::animation::Channel {
            sampler: json::Index::new(0),
            target: json::animation::Target {
                extensions: None,
                extras: Default::default(),
                node,
                path: Valid(json::animation::Property::MorphTargetWeights),
            },
            extensions: None,
            extras: Default::default(),
        }],
        name: Some("simulation".into()),
        samplers: vec![sampler],
    });
    doc.finish()
}

/// A glTF document and its binary chunk, built together.
#[derive(Default)]
struct Document {
    root: json::Root,
    bin: Vec<u8>,
}

impl Document {
    /// Appends `data` as a buffer view of its own and an accessor over it.
    fn accessor<T: bytemuck::Pod>(
        &mut self,
        data: &[T],
        target: Option<json::buffer::Target>,
        kind: json::accessor::Type,
        range: Option<(json::Value, json::Value)>,
    ) -> json::Index<json::Accessor> {
        self.view_and_accessor(bytemuck::cast_slice(data), target, kind, json::accessor::ComponentType::F32, range)
    }

    fn view_and_accessor(
        &mut self,
        bytes: &[u8],
        target: Option<json::buffer::Target>,
        kind: json::accessor::Type,
        component: json::accessor::ComponentType,
        range: Option<(json::Value, json::Value)>,
    ) -> json::Index<json::Accessor> {
        // Every element here is 4-byte aligned, so views start aligned.
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        let view = self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            extensions: None,
            extras: Default::default(),
            name: None,
            target: target.map(Valid),
        });
        let components = match kind {
            json::accessor::Type::Scalar => 1,
            json::accessor::Type::Vec2 => 2,
            json::accessor::Type::Vec3 => 3,
            _ => 4,
        };
        let (min, max) = range.unzip();
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(bytes.len() / (4 * components)),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: Default::default(),
            type_: Valid(kind),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    /// Vec3 data; with `bounded`, the accessor carries its min and max (glTF
    /// requires them on positions and position targets).
    fn vec3s(&mut self, data: &[Vec3], target: json::buffer::Target, bounded: bool) -> json::Index<json::Accessor> {
        let range = bounded.then(|| {
            let (min, max) = crate::sim::mesh::bounds(data);
            (json::Value::from(min.to_array().to_vec()), json::Value::from(max.to_array().to_vec()))
        });
        self.accessor(data, Some(target), json::accessor::Type::Vec3, range)
    }

    fn indices(&mut self, data: &[u32]) -> json::Index<json::Accessor> {
        self.view_and_accessor(
            bytemuck::cast_slice(data),
            Some(json::buffer::Target::ElementArrayBuffer),
            json::accessor::Type::Scalar,
            json::accessor::ComponentType::U32,
            None,
        )
    }

    /// The document's JSON and binary chunk packed into .glb bytes.
    fn finish(mut self) -> Result<Vec<u8>, ExportError> {
        self.root.push(json::Buffer {
            byte_length: USize64::from(self.bin.len()),
            extensions: None,
            extras: Default::default(),
            name: None,
            uri: None,
        });
        self.root.asset.generator = Some(format!("drape {}", env!("CARGO_PKG_VERSION")));
        let text = json::serialize::to_string(&self.root).map_err(|e| ExportError::Gltf(e.to_string()))?;
        let glb = gltf::binary::Glb {
            header: gltf::binary::Header { magic: *b"glTF", version: 2, length: 0 },
            json: text.into_bytes().into(),
            bin: Some(self.bin.into()),
        };
        glb.to_vec().map_err(|e| ExportError::Gltf(e.to_string()))
    }
}
