// vlt/models.h — look up the generated models by name.
#pragma once

#include <span>
#include <string_view>

#include "vlt/model_info.h"

namespace vlt {

// Every model vlt-gen generated from models/, sorted by name.
std::span<const ModelInfo* const> AllModels();

// The model called `name`, or nullptr.
const ModelInfo* FindModel(std::string_view name);

// Index of the parameter / reading / output called `name` in `model`, or -1.
int FindParam(const ModelInfo& model, std::string_view name);

}  // namespace vlt
