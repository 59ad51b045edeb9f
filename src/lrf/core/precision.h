#pragma once
// The arithmetic the autoencoders run in. bf16 (with float32 accumulation inside the convolutions) is
// several times faster than fp32 on CPUs with native bf16 (cpu_features.h) and costs a little accuracy;
// "auto" picks it exactly there. Tensors handed to and returned by the autoencoders stay float32 either
// way (see Autoencoder::set_precision).
#include <string>

namespace lrf {

enum class Precision { fp32, bf16, automatic };

// "fp32", "bf16" or "auto"; anything else is an lrf::Error naming `source` and the allowed values.
Precision parse_precision(const std::string& text, const std::string& source = "--precision");
// "fp32", "bf16" or "auto".
std::string precision_name(Precision p);
// automatic -> bf16 where cpu_has_bf16(), else fp32; fp32 and bf16 are returned as they are.
Precision resolve_precision(Precision p);

// The precision load_autoencoder gives every model it builds: `lrf --precision` sets it; until then it
// is $LRF_PRECISION when set (tests force a choice with it), else automatic.
Precision default_precision();
void set_default_precision(Precision p);

}  // namespace lrf
