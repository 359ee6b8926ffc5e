#include "vlt/models.h"

namespace vlt {

std::span<const ModelInfo* const> AllModels() { return {generated::kModels, generated::kNumModels}; }

const ModelInfo* FindModel(std::string_view name) {
  for (const ModelInfo* model : AllModels()) {
    if (name == model->name) return model;
  }
  return nullptr;
}

int FindParam(const ModelInfo& model, std::string_view name) {
  for (int k = 0; k < model.num_params; ++k) {
    if (name == model.params[k].name) return k;
  }
  return -1;
}

}  // namespace vlt
