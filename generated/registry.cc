// Placeholder until vlt-gen writes the registry.
#include "vlt/model_info.h"
namespace vlt::generated {
extern const ModelInfo* const kModels[] = {nullptr};
extern const std::size_t kNumModels = 0;
}  // namespace vlt::generated
