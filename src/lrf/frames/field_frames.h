#pragma once
// Frames of a trained field for any camera, whatever its kind: an RGB field is rendered directly; a
// latent field (or a feature field lifted to the latent) and a latent NeRF are rendered at latent
// resolution (the camera's size / 8) and decoded, by the decoder a refined field was fitted through (as
// lrf eval and lrf render use it), the autoencoder's, or an override. Used by camera-path videos and by
// the viewer's server. Which kind a folder holds is told by field_kinds/field_type.h (open_field_frames).
#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "lrf/splat/run/field_kind.h"
#include "lrf/scene/scene.h"

namespace lrf {

struct FrameTiming {
  double render_ms = 0;  // splatting
  double decode_ms = 0;  // latent fields: the decoder (0 for RGB fields)
  double detail_ms = 0;  // the detail pass, when one is applied (detail/detail_frames.h)
};

class FieldFrames {
 public:
  virtual ~FieldFrames() = default;

  virtual FieldKind kind() const = 0;
  // Frames are decoded from rendered latents (every kind but rgb).
  virtual bool latent() const = 0;
  // depth() gives the field's surface (splat fields; a latent NeRF has none here).
  virtual bool has_depth() const = 0;
  // The scene at the field's training resolution (latent fields: cropped to multiples of 8).
  virtual const Scene& scene() const = 0;
  // Frame sizes must be multiples of this (8 for latent fields: the decoder upsamples by 8).
  virtual int size_multiple() const = 0;
  // One line for logs: the space, size, channels, autoencoder and decoder.
  virtual std::string describe() const = 0;
  // The frame `camera` sees, as 8-bit RGB (CV_8UC3), camera.width x camera.height. Not thread-safe:
  // callers serialise (rendering and decoding use every worker thread anyway).
  virtual cv::Mat render(const Camera& camera, FrameTiming* timing = nullptr) = 0;
  // The field's surface as `camera` sees it, at the camera's own size: camera-space z per pixel (CV_32F),
  // the opacity-weighted mean depth of the Gaussians a pixel's ray meets, 0 where they cover less than half
  // of it. Splat fields only (a latent NeRF throws lrf::Error): the Gaussians are 3D, so their depth is sharp
  // at any resolution even when their features were fitted at latent resolution.
  virtual cv::Mat depth(const Camera& camera) = 0;
};

// The frames of each kind's output folder (lrf train or lrf refine, or a method's folder of lrf compare).
// `decoder` replaces a latent field's or NeRF's decoder (Stage III weights). Throw lrf::Error naming the
// file on a bad folder.
std::unique_ptr<FieldFrames> rgb_field_frames(const std::string& run);
std::unique_ptr<FieldFrames> latent_field_frames(const std::string& run, const std::string& decoder);
std::unique_ptr<FieldFrames> nerf_field_frames(const std::string& run, const std::string& decoder);

}  // namespace lrf
