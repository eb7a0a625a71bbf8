//! Render targets: the multisampled colour and depth-stencil textures a
//! frame is drawn into, offscreen colour textures, and reading them back.

/// The depth-stencil format: depth for occlusion, stencil so that the
/// shadow darkens each ground pixel once.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth24PlusStencil8;

/// Samples per pixel the renderer uses with `format` on `adapter`: 4 when
/// both it and the depth format support that, else 1.
pub fn msaa_samples(adapter: &wgpu::Adapter, format: wgpu::TextureFormat) -> u32 {
    let colour = adapter.get_texture_format_features(format).flags;
    let depth = adapter.get_texture_format_features(DEPTH_FORMAT).flags;
    if colour.sample_count_supported(4)
        && depth.sample_count_supported(4)
        && colour.contains(wgpu::TextureFormatFeatureFlags::MULTISAMPLE_RESOLVE)
    {
        4
    } else {
        1
    }
}

/// The textures a frame of one size needs besides the target itself.
#[derive(Debug)]
pub(crate) struct FrameTargets {
    pub size: (u32, u32),
    /// Multisampled colour, resolved into the target; `None` without MSAA.
    /// Only `RENDER_ATTACHMENT`: on wgpu's GL backend a multisampled texture
    /// with any other usage renders black.
    pub msaa: Option<wgpu::TextureView>,
    pub depth: wgpu::TextureView,
}

impl FrameTargets {
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat, samples: u32, size: (u32, u32)) -> Self {
        let extent = wgpu::Extent3d { width: size.0.max(1), height: size.1.max(1), depth_or_array_layers: 1 };
        let texture = |label, format, samples| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: extent,
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
        };
        let msaa = (samples > 1)
            .then(|| texture("msaa colour", format, samples).create_view(&wgpu::TextureViewDescriptor::default()));
        let depth = texture("depth", DEPTH_FORMAT, samples).create_view(&wgpu::TextureViewDescriptor::default());
        Self { size, msaa, depth }
    }
}

/// Why an image could not be read back from the GPU.
#[derive(Debug, thiserror::Error)]
pub enum ReadbackError {
    /// Waiting for the GPU failed (device lost or timed out).
    #[error("waiting for the GPU failed: {0}")]
    Poll(wgpu::PollError),
    /// Mapping the buffer failed.
    #[error("cannot map the readback buffer: {0}")]
    Map(String),
    /// The texture's format is not 8-bit RGBA or BGRA.
    #[error("cannot read back a {0:?} texture as RGBA8")]
    Format(wgpu::TextureFormat),
    /// The image is larger than the device can hold as one texture or read
    /// back in one buffer.
    #[error(
        "a {width} × {height} image is too large for this adapter: at most {max_side} pixels a side and \
         {max_bytes} bytes of pixels ({width} × {height} needs {needed} bytes); ask for a smaller size"
    )]
    TooLarge {
        /// Asked-for width, pixels.
        width: u32,
        /// Asked-for height, pixels.
        height: u32,
        /// The device's largest 2-D texture side, pixels.
        max_side: u32,
        /// The device's largest buffer, bytes.
        max_bytes: u64,
        /// The readback buffer this image needs, bytes.
        needed: u64,
    },
    /// The GPU rejected the work (a validation or out-of-memory error
    /// caught while drawing the image).
    #[error("the GPU could not draw the image: {0}")]
    Gpu(String),
}

/// A single-sampled colour texture to render into and read back.
#[derive(Debug)]
pub struct OffscreenTarget {
    /// The texture (`RENDER_ATTACHMENT | COPY_SRC`).
    pub texture: wgpu::Texture,
    /// A view of it, to render into.
    pub view: wgpu::TextureView,
}

impl OffscreenTarget {
    /// The colour format offscreen images use: 8-bit RGBA, not sRGB (the
    /// shaders encode), which is also what egui prefers.
    pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

    /// A `width × height` target in [`Self::FORMAT`].
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Result<Self, ReadbackError> {
        Self::with_format(device, width, height, Self::FORMAT)
    }

    /// A `width × height` target in `format`, which must be 8-bit RGBA or
    /// BGRA to be read back (a window's surface format, for screenshots
    /// drawn by a renderer made for the window). Sizes the device cannot
    /// hold, as a texture or as the buffer [`Self::read`] copies into, are
    /// an error here rather than a wgpu validation panic later.
    pub fn with_format(
        device: &wgpu::Device,
        width: u32,
        height: u32,
        format: wgpu::TextureFormat,
    ) -> Result<Self, ReadbackError> {
        let limits = device.limits();
        let needed = u64::from(padded_row_bytes(width.max(1))) * u64::from(height.max(1));
        if width.max(height) > limits.max_texture_dimension_2d || needed > limits.max_buffer_size {
            return Err(ReadbackError::TooLarge {
                width,
                height,
                max_side: limits.max_texture_dimension_2d,
                max_bytes: limits.max_buffer_size,
                needed,
            });
        }
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("offscreen"),
            size: wgpu::Extent3d { width: width.max(1), height: height.max(1), depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        Ok(Self { texture, view })
    }

    /// Copies the texture to the CPU as an RGBA image (waits for the GPU).
    pub fn read(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<image::RgbaImage, ReadbackError> {
        read_texture(device, queue, &self.texture)
    }
}

/// Copies an 8-bit RGBA or BGRA texture with `COPY_SRC` usage to the CPU.
///
/// Rows in a buffer copy must start at multiples of 256 bytes
/// ([`wgpu::COPY_BYTES_PER_ROW_ALIGNMENT`]); the padding is dropped here.
pub fn read_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> Result<image::RgbaImage, ReadbackError> {
    use wgpu::TextureFormat as F;
    let swap_red_blue = match texture.format() {
        F::Rgba8Unorm | F::Rgba8UnormSrgb => false,
        F::Bgra8Unorm | F::Bgra8UnormSrgb => true,
        other => return Err(ReadbackError::Format(other)),
    };
    let (width, height) = (texture.width(), texture.height());
    let row = width * 4;
    let padded_row = padded_row_bytes(width);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: u64::from(padded_row) * u64::from(height),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded_row), rows_per_image: None },
        },
        texture.size(),
    );
    queue.submit([encoder.finish()]);
    let (sender, receiver) = std::sync::mpsc::channel();
    buffer.slice(..).map_async(wgpu::MapMode::Read, move |result| {
        let _ = sender.send(result);
    });
    device.poll(wgpu::PollType::wait_indefinitely()).map_err(ReadbackError::Poll)?;
    match receiver.recv() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return Err(ReadbackError::Map(e.to_string())),
        Err(_) => return Err(ReadbackError::Map("the map callback never ran".into())),
    }
    let mut pixels = Vec::with_capacity((row * height) as usize);
    {
        let mapped = buffer.slice(..).get_mapped_range().map_err(|e| ReadbackError::Map(e.to_string()))?;
        for padded in mapped.chunks(padded_row as usize) {
            pixels.extend_from_slice(&padded[..row as usize]);
        }
    }
    buffer.unmap();
    if swap_red_blue {
        for px in pixels.chunks_exact_mut(4) {
            px.swap(0, 2);
        }
    }
    image::RgbaImage::from_raw(width, height, pixels)
        .ok_or_else(|| ReadbackError::Map("the copied image has the wrong size".into()))
}

/// Bytes of one row of 8-bit RGBA pixels in a buffer copy, padded to
/// [`wgpu::COPY_BYTES_PER_ROW_ALIGNMENT`].
fn padded_row_bytes(width: u32) -> u32 {
    (width * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT
}

/// Writes an RGBA image as a PNG with the strongest compression (screenshots
/// and golden images are written once and kept).
pub fn write_png(path: &std::path::Path, image: &image::RgbaImage) -> Result<(), image::ImageError> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
    let encoder = PngEncoder::new_with_quality(file, CompressionType::Best, FilterType::Adaptive);
    image.write_with_encoder(encoder)
}
