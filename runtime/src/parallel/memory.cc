#include "parallel/memory.h"

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>

#include "parallel/pool.h"

namespace vlt::parallel_internal {

void MapPages(void* begin, std::size_t bytes, int threads) {
#ifdef MADV_POPULATE_WRITE
  constexpr std::size_t kMinBytes = std::size_t{8} << 20, kItems = 128;
  if (bytes < kMinBytes || ResolveThreads(threads) < 2) return;
  const std::uintptr_t page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  const std::uintptr_t first = (reinterpret_cast<std::uintptr_t>(begin) + page - 1) / page;
  const std::uintptr_t last = (reinterpret_cast<std::uintptr_t>(begin) + bytes) / page;  // excluded
  const std::uintptr_t pages = last - first;
  ForEach(kItems, threads, [&](std::size_t item, int) {
    const std::uintptr_t from = first + pages * item / kItems, to = first + pages * (item + 1) / kItems;
    // Best effort: EINVAL (an older kernel) or ENOMEM leave the pages to the first touch.
    if (to > from) ::madvise(reinterpret_cast<void*>(from * page), (to - from) * page, MADV_POPULATE_WRITE);
  });
#else
  (void)begin;
  (void)bytes;
  (void)threads;
#endif
}

}  // namespace vlt::parallel_internal
