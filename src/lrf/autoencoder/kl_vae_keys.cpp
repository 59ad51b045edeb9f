#include "lrf/autoencoder/kl_vae_keys.h"

#include <regex>

#include <ATen/ATen.h>

#include "lrf/core/error.h"

namespace lrf {
namespace {

bool starts_with(const std::string& s, const std::string& p) { return s.rfind(p, 0) == 0; }

StateDict strip_prefix(const StateDict& file) {
  for (const std::string prefix : {"first_stage_model.", "vae."}) {
    bool any = false;
    for (const auto& item : file) any = any || starts_with(item.key(), prefix);
    if (!any) continue;
    // A full Stable Diffusion checkpoint: keep only the VAE's keys.
    StateDict out;
    for (const auto& item : file)
      if (starts_with(item.key(), prefix)) out.insert(item.key().substr(prefix.size()), item.value());
    return out;
  }
  return file;
}

}  // namespace

StateDict kl_keys_to_ldm(const StateDict& input, int num_up_levels) {
  StateDict file = strip_prefix(input);
  static const std::regex up_re(R"(^decoder\.up_blocks\.(\d+)\.(resnets\.(\d+)|upsamplers\.0)\.(.*)$)");
  std::smatch m;
  if (num_up_levels <= 0) {
    for (const auto& item : file) {
      if (std::regex_match(item.key(), m, up_re)) num_up_levels = std::max(num_up_levels, std::stoi(m[1]) + 1);
    }
  }
  // Ordered (pattern, replacement) rules; the first match wins.
  static const std::vector<std::pair<std::regex, std::string>> rules = {
      {std::regex(R"(^(encoder|decoder)\.conv_norm_out\.(.*)$)"), "$1.norm_out.$2"},
      {std::regex(R"(^encoder\.down_blocks\.(\d+)\.resnets\.(\d+)\.(.*)$)"), "encoder.down.$1.block.$2.$3"},
      {std::regex(R"(^encoder\.down_blocks\.(\d+)\.downsamplers\.0\.conv\.(.*)$)"), "encoder.down.$1.downsample.conv.$2"},
      {std::regex(R"(^(encoder|decoder)\.mid_block\.resnets\.0\.(.*)$)"), "$1.mid.block_1.$2"},
      {std::regex(R"(^(encoder|decoder)\.mid_block\.resnets\.1\.(.*)$)"), "$1.mid.block_2.$2"},
      {std::regex(R"(^(encoder|decoder)\.mid_block\.attentions\.0\.group_norm\.(.*)$)"), "$1.mid.attn_1.norm.$2"},
      {std::regex(R"(^(encoder|decoder)\.mid_block\.attentions\.0\.(to_q|query)\.(.*)$)"), "$1.mid.attn_1.q.$3"},
      {std::regex(R"(^(encoder|decoder)\.mid_block\.attentions\.0\.(to_k|key)\.(.*)$)"), "$1.mid.attn_1.k.$3"},
      {std::regex(R"(^(encoder|decoder)\.mid_block\.attentions\.0\.(to_v|value)\.(.*)$)"), "$1.mid.attn_1.v.$3"},
      {std::regex(R"(^(encoder|decoder)\.mid_block\.attentions\.0\.(to_out\.0|proj_attn)\.(.*)$)"),
       "$1.mid.attn_1.proj_out.$3"},
  };
  static const std::regex shortcut_re(R"(^(.*\.block(_\d|\.\d+)\.)conv_shortcut\.(.*)$)");
  static const std::regex attn_weight_re(R"(^.*\.attn_1\.(q|k|v|proj_out)\.weight$)");

  StateDict out;
  for (const auto& item : file) {
    std::string key = item.key();
    at::Tensor value = item.value();
    if (std::regex_match(key, m, up_re)) {
      if (num_up_levels <= 0) fail("kl-f8: cannot number decoder levels");
      int level = num_up_levels - 1 - std::stoi(m[1]);
      std::string part = m[3].matched ? "block." + m[3].str() : "upsample";
      std::string rest = m[4].str();
      if (!m[3].matched && starts_with(rest, "conv.")) rest = rest.substr(5), part += ".conv";
      key = "decoder.up." + std::to_string(level) + "." + part + "." + rest;
    } else {
      for (const auto& [re, replacement] : rules) {
        if (std::regex_match(key, re)) {
          key = std::regex_replace(key, re, replacement);
          break;
        }
      }
    }
    if (std::regex_match(key, m, shortcut_re)) key = m[1].str() + "nin_shortcut." + m[3].str();
    // diffusers stores attention projections as Linear [out, in]; ldm as 1x1 convs.
    if (value.dim() == 2 && std::regex_match(key, attn_weight_re)) value = value.reshape({value.size(0), value.size(1), 1, 1});
    if (out.contains(key)) fail("kl-f8: key " + key + " appears twice after renaming");
    out.insert(key, value);
  }
  return out;
}

}  // namespace lrf
