// calibration/internal.h — what the calibration folder's writers share (internal to
// runtime/src/calibration/).
#pragma once

#include <string>

#include "vlt/model_info.h"

namespace vlt::calibration_internal {

// A parameter named in words beside its symbol (the model spec's description; issue 34): "" when
// the model or the name is unknown.
inline std::string ParameterMeaning(const ModelInfo* model, const std::string& name) {
  if (model == nullptr) return "";
  for (int k = 0; k < model->num_params; ++k) {
    if (name == model->params[k].name) return model->params[k].description;
  }
  return "";
}

}  // namespace vlt::calibration_internal
