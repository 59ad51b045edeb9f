#pragma once
// What Stage I and Stage III do alike around their output file OUT (OUT.safetensors, its record and its
// checkpoint): claim it before any work, stop with one clear error when the loss stops being finite, and
// note the precision the steps ran at in the checkpoint.
#include <cstdint>
#include <map>
#include <string>
#include <utility>

#include "lrf/core/folder_lock.h"
#include "lrf/core/precision.h"

namespace lrf {

// Creates OUT's folder, locks OUT against a second job (before the checks, so that a second job cannot
// remove or overwrite this one's checkpoint), and refuses an existing OUT unless force or resume; resume
// needs the checkpoint. Hold the returned lock while writing.
FolderLock claim_finetune_output(const std::string& out, const std::string& checkpoint, bool force, bool resume);

// Throws lrf::Error naming OUT, the loss, the 1-based step and the last checkpoint.
[[noreturn]] void fail_non_finite_loss(const std::string& out, double loss, int64_t step,
                                       const std::string& checkpoint);

// The checkpoint metadata entry naming the precision (fp32 / bf16) the steps ran at.
std::pair<std::string, std::string> precision_metadata(Precision precision);
// A run resumed at another precision than its checkpoint's continues correctly but cannot reproduce an
// uninterrupted run bit for bit: say so (a warning, not an error: the checkpoint is still valid).
void warn_if_precision_changed(const std::map<std::string, std::string>& checkpoint_metadata, Precision now,
                               const std::string& checkpoint);

}  // namespace lrf
