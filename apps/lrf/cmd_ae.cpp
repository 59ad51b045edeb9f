// lrf ae: run the autoencoders on images and convert weights.
//   roundtrip  encode + decode images, report PSNR and times
//   encode     image -> latent (.safetensors, tensor "latent" [C, H/8, W/8], raw float32)
//   decode     latent -> image
//   convert    any supported checkpoint -> .safetensors
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include "autoencoder_option.h"
#include "command.h"
#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/eval/metrics.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/core/paths.h"
#include "lrf/core/run_info.h"
#include "lrf/core/safetensors.h"
#include "lrf/core/threads.h"

namespace {

constexpr const char* kCropNote =
    "Images whose width or height is not a multiple of 8 are centre-cropped to the largest multiple of 8 "
    "(e.g. 504x378 -> 504x376), as the paper's code does.";

struct ModelOptions {
  std::string autoencoder = "taef2";
  std::string encoder;
  std::string decoder;
  bool contiguous = false;
};

void add_model_options(CLI::App* cmd, const std::shared_ptr<ModelOptions>& m) {
  lrf::cli::add_autoencoder_option(cmd, &m->autoencoder, "to run");
  cmd->add_option("--encoder", m->encoder, "Replace the encoder's weights with this checkpoint (e.g. fine-tuned)");
  cmd->add_option("--decoder", m->decoder, "Replace the decoder's weights with this checkpoint (e.g. fine-tuned)");
  cmd->add_flag("--no-channels-last", m->contiguous,
                "Run convolutions in NCHW layout instead of the default channels-last (slower on CPU; for comparison)");
}

std::unique_ptr<lrf::Autoencoder> load_model(const ModelOptions& m) {
  auto ae = lrf::load_autoencoder(m.autoencoder, m.encoder, m.decoder);
  if (m.contiguous) ae->set_channels_last(false);
  lrf::log_info("autoencoder: " + ae->description() + ", " + lrf::precision_name(ae->precision()));
  return ae;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Reads an image, area-resizes it by `downscale` as a scene's --downscale does (each side divided and
// rounded), centre-crops it; returns [1,3,H,W] and fills the crop description.
at::Tensor load_image(const std::string& path, cv::Size* original, cv::Size* cropped, int downscale = 1) {
  cv::Mat image = lrf::read_image_rgb(path);
  *original = image.size();
  if (downscale > 1) {
    image = lrf::resize_area(image, std::max(1, static_cast<int>(std::lround(double(image.cols) / downscale))),
                             std::max(1, static_cast<int>(std::lround(double(image.rows) / downscale))));
  }
  cv::Mat crop;
  try {
    crop = lrf::center_crop_to_multiple(image, 8);
  } catch (const lrf::Error& e) {
    lrf::fail(path, e.what());
  }
  *cropped = crop.size();
  return lrf::image_to_batch(crop);
}

struct RoundtripOptions {
  std::vector<std::string> images;
  int downscale = 1;
  bool json = false;
  std::string output_dir;
};

// The file `lrf ae roundtrip -o DIR` writes the decode of `image` to.
std::string roundtrip_output(const std::string& dir, const std::string& image) {
  return (std::filesystem::path(dir) / (std::filesystem::path(image).stem().string() + ".png")).string();
}

int run_roundtrip(const ModelOptions& m, const RoundtripOptions& o) {
  torch::NoGradGuard no_grad;
  if (!o.output_dir.empty()) {
    // Checked before any work: a decode written over an input image (`-o .` beside the PNGs) would replace
    // the photo, and two images of one name would leave only the later decode.
    std::set<std::string> targets;
    for (const auto& image : o.images) {
      const std::string target = roundtrip_output(o.output_dir, image);
      for (const auto& input : o.images) lrf::refuse_output_over_input(target, input, "an input image");
      if (!targets.insert(lrf::canonical_path(target)).second)
        lrf::fail_usage(target + ": two of the images would both be decoded to this file (their names differ only "
                                 "in the extension or folder)");
    }
  }
  auto ae = load_model(m);
  nlohmann::json items = nlohmann::json::array();
  double psnr_sum = 0, enc_sum = 0, dec_sum = 0;
  bool warmed_up = false;
  if (!o.json) std::printf("%-40s %9s %8s %9s %9s\n", "image", "size", "PSNR dB", "encode s", "decode s");
  for (const auto& path : o.images) {
    cv::Size original, cropped;
    at::Tensor x = load_image(path, &original, &cropped, o.downscale);
    if (!warmed_up) {
      // The first call builds oneDNN kernels for this size; keep that out of the reported times.
      ae->decode(ae->encode(x));
      warmed_up = true;
    }
    auto t0 = std::chrono::steady_clock::now();
    at::Tensor z = ae->encode(x);
    double enc = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    at::Tensor y = ae->decode(z);
    double dec = seconds_since(t0);
    double p = lrf::psnr(y.squeeze(0), x.squeeze(0));
    psnr_sum += p;
    enc_sum += enc;
    dec_sum += dec;
    std::string size = std::to_string(cropped.width) + "x" + std::to_string(cropped.height);
    if (!o.json) std::printf("%-40s %9s %8.2f %9.3f %9.3f\n", path.c_str(), size.c_str(), p, enc, dec);
    if (!o.output_dir.empty()) lrf::write_image_rgb(roundtrip_output(o.output_dir, path), lrf::tensor_to_image(y));
    items.push_back({{"path", path},
                     {"width", cropped.width},
                     {"height", cropped.height},
                     {"original_width", original.width},
                     {"original_height", original.height},
                     {"psnr", p},
                     {"encode_seconds", enc},
                     {"decode_seconds", dec}});
  }
  const double n = static_cast<double>(o.images.size());
  if (o.json) {
    nlohmann::json out = {{"autoencoder", ae->description()},
                          {"latent_channels", ae->latent_channels()},
                          {"precision", lrf::precision_name(ae->precision())},
                          {"threads", lrf::thread_count()},
                          {"psnr_mean", psnr_sum / n},
                          {"encode_seconds_mean", enc_sum / n},
                          {"decode_seconds_mean", dec_sum / n},
                          {"images", items},
                          {"versions", lrf::version_info()}};
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    std::printf("mean over %zu images: PSNR %.3f dB, encode %.3f s, decode %.3f s (%d threads, %s)\n",
                o.images.size(), psnr_sum / n, enc_sum / n, dec_sum / n, lrf::thread_count(),
                lrf::precision_name(ae->precision()).c_str());
  }
  return 0;
}

struct EncodeOptions {
  std::string image;
  std::string output;
  bool sample = false;
};

int run_encode(const ModelOptions& m, const EncodeOptions& o) {
  torch::NoGradGuard no_grad;
  lrf::refuse_output_over_input(o.output, o.image, "the input image");
  auto ae = load_model(m);
  cv::Size original, cropped;
  at::Tensor x = load_image(o.image, &original, &cropped);
  at::Tensor z = o.sample ? ae->encode_sample(x) : ae->encode(x);
  lrf::StateDict out;
  out.insert("latent", z[0].contiguous());
  lrf::write_safetensors(o.output, out,
                         {{"lrf_autoencoder", ae->description()},
                          {"lrf_image", o.image},
                          {"lrf_image_size", std::to_string(original.width) + "x" + std::to_string(original.height)},
                          {"lrf_crop", std::to_string(cropped.width) + "x" + std::to_string(cropped.height) + " centred"},
                          {"lrf_posterior", o.sample ? "sample" : "mean"}});
  lrf::log_info("wrote " + o.output + ": latent [" + std::to_string(z.size(1)) + ", " + std::to_string(z.size(2)) +
                ", " + std::to_string(z.size(3)) + "]");
  return 0;
}

struct DecodeOptions {
  std::string latent;
  std::string output;
};

int run_decode(const ModelOptions& m, const DecodeOptions& o) {
  torch::NoGradGuard no_grad;
  lrf::refuse_output_over_input(o.output, o.latent, "the input latent");
  lrf::StateDict sd = lrf::load_state_dict(o.latent);
  const at::Tensor* z = sd.find("latent");
  if (!z) lrf::fail(o.latent, "no tensor named 'latent' (write one with `lrf ae encode`)");
  at::Tensor latent = z->to(torch::kFloat);
  if (latent.dim() == 3) latent = latent.unsqueeze(0);
  if (latent.dim() != 4 || latent.size(0) != 1) lrf::fail(o.latent, "'latent' must be [C, h, w] or [1, C, h, w]");
  auto ae = load_model(m);
  if (latent.size(1) != ae->latent_channels()) {
    lrf::fail(o.latent, "latent has " + std::to_string(latent.size(1)) + " channels but the autoencoder expects " +
                            std::to_string(ae->latent_channels()));
  }
  at::Tensor y = ae->decode(latent);
  lrf::write_image_rgb(o.output, lrf::tensor_to_image(y));
  lrf::log_info("wrote " + o.output + " (" + std::to_string(y.size(3)) + "x" + std::to_string(y.size(2)) + ")");
  return 0;
}

struct ConvertOptions {
  std::string input;
  std::string output;
  std::string dtype = "keep";
};

int run_convert(const ConvertOptions& o) {
  lrf::refuse_output_over_input(o.output, o.input, "the checkpoint being converted");
  lrf::StateDict sd = lrf::load_state_dict(o.input);
  lrf::StateDict out;
  for (const auto& item : sd) {
    at::Tensor t = item.value();
    if (t.is_floating_point()) {
      if (o.dtype == "f32") t = t.to(torch::kFloat);
      if (o.dtype == "f16") t = t.to(torch::kHalf);
      if (o.dtype == "bf16") t = t.to(torch::kBFloat16);
    }
    out.insert(item.key(), t.contiguous());
  }
  lrf::write_safetensors(o.output, out, {{"lrf_converted_from", o.input}});
  lrf::log_info("wrote " + o.output + ": " + std::to_string(out.size()) + " tensors");
  return 0;
}

lrf::cli::CommandRegistration reg(40, [](CLI::App& root) {
  auto* ae = root.add_subcommand("ae", "Autoencoders: round trip, encode, decode, convert weights");
  ae->require_subcommand(1);

  auto* rt = ae->add_subcommand("roundtrip", std::string("Encode and decode images; print per-image PSNR (peak 1, "
                                                         "float images in [0,1]) and encode/decode times (after one "
                                                         "untimed warm-up pass). ") + kCropNote);
  auto rm = std::make_shared<ModelOptions>();
  auto ro = std::make_shared<RoundtripOptions>();
  rt->add_option("images", ro->images, "Images to round-trip (PNG, JPG, ...)")->required()->check(CLI::ExistingFile);
  add_model_options(rt, rm);
  rt->add_option("--downscale", ro->downscale,
                 "Area-resize each image by this integer factor first, as a scene's --downscale does (e.g. 2 for "
                 "LLFF flower and room at about 500x375)")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  rt->add_flag("--json", ro->json, "Print one JSON object (keys psnr_mean, images, ...) instead of a table");
  rt->add_option("--output-dir,-o", ro->output_dir, "Also write each decoded image here as <name>.png")
      ->check(CLI::ExistingDirectory);
  lrf::cli::on_run(rt, [rm, ro] { return run_roundtrip(*rm, *ro); });

  auto* enc = ae->add_subcommand("encode", std::string("Encode an image to a latent: a .safetensors file with one "
                                                       "float32 tensor 'latent' [C, H/8, W/8], raw as the encoder "
                                                       "outputs it (KL-VAE: posterior mean, unscaled). ") + kCropNote);
  auto em = std::make_shared<ModelOptions>();
  auto eo = std::make_shared<EncodeOptions>();
  enc->add_option("image", eo->image, "Image to encode")->required()->check(CLI::ExistingFile);
  enc->add_option("-o,--output", eo->output, "Output latent file (.safetensors)")->required();
  add_model_options(enc, em);
  enc->add_flag("--sample", eo->sample, "KL-VAE: sample the posterior instead of taking its mean");
  lrf::cli::on_run(enc, [em, eo] { return run_encode(*em, *eo); });

  auto* dec = ae->add_subcommand("decode", "Decode a latent file (tensor 'latent', [C,h,w] or [1,C,h,w]) to an image "
                                           "of 8h x 8w pixels");
  auto dm = std::make_shared<ModelOptions>();
  auto dopt = std::make_shared<DecodeOptions>();
  dec->add_option("latent", dopt->latent, "Latent file (.safetensors, as written by `lrf ae encode`)")
      ->required()
      ->check(CLI::ExistingFile);
  dec->add_option("-o,--output", dopt->output, "Output image (.png or .jpg)")->required();
  add_model_options(dec, dm);
  lrf::cli::on_run(dec, [dm, dopt] { return run_decode(*dm, *dopt); });

  auto* conv = ae->add_subcommand("convert", "Convert a checkpoint (.pth/.ckpt PyTorch zip, or .safetensors) to "
                                             ".safetensors, keeping tensor names and order. Only tensors are read; "
                                             "nothing in the checkpoint is executed.");
  auto co = std::make_shared<ConvertOptions>();
  conv->add_option("input", co->input, "Checkpoint to convert")->required()->check(CLI::ExistingFile);
  conv->add_option("-o,--output", co->output, "Output .safetensors file")->required();
  conv->add_option("--dtype", co->dtype, "Floating-point dtype of the output: keep, f32, f16 or bf16")
      ->check(CLI::IsMember({"keep", "f32", "f16", "bf16"}))
      ->capture_default_str();
  lrf::cli::on_run(conv, [co] { return run_convert(*co); });
});

}  // namespace
