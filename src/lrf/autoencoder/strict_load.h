#pragma once
// Copies a state dict into a module's parameters and buffers, strictly: a missing, unexpected or
// mis-shaped key is an error that lists all of them (silently keeping random weights is the failure
// this prevents). Values are converted to the parameter's dtype.
#include <string>

#include <torch/nn/module.h>

#include "lrf/core/state_dict.h"

namespace lrf {

// `what` names the weights in the error (e.g. "models/taef2/taef2_encoder.pth (tiny encoder)").
void load_strict(torch::nn::Module& module, const StateDict& weights, const std::string& what);
// The mismatch as one line ("missing 2 keys: a, b; unexpected ...;"), empty if the weights fit. Lets a
// caller that loads several modules report every problem at once.
std::string strict_mismatch(torch::nn::Module& module, const StateDict& weights);
// The module's parameters and buffers as float32 copies, in registration order.
StateDict module_state(const torch::nn::Module& module);

}  // namespace lrf
