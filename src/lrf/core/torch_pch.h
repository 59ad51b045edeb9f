#pragma once
// Precompiled header: libtorch's headers take seconds per translation unit to parse, so every target
// parses them once here. Source files still include what they use.
#include <torch/torch.h>
#include <opencv2/core.hpp>
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>
