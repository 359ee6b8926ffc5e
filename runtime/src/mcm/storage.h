// mcm/storage.h — where the Monte Carlo engine keeps the values of a run (internal).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <new>
#include <utility>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace vlt::mcm_internal {

// An allocator whose resize leaves the elements uninitialised. The stored values of a run
// (4 bytes x M x outputs) and the region's distances are written by the threads that compute them,
// so their pages are first touched - a page fault each, the dominant cost of storing them - on
// every thread at once, instead of by one thread zeroing them beforehand. Blocks of 4 MiB and more
// are aligned to 2 MiB and offered to the kernel's transparent huge pages (madvise; a mere hint,
// ignored where they are off): one fault per 2 MiB instead of per 4 KiB (page faults were 8 % of
// a 10^6-trial run on this machine's virtualised kernel).
template <typename T>
struct UninitializedAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = UninitializedAllocator<U>;
  };
  UninitializedAllocator() = default;
  template <typename U>
  UninitializedAllocator(const UninitializedAllocator<U>&) noexcept {}
  static constexpr std::size_t kHugePage = std::size_t{2} << 20;
  static bool Huge(std::size_t n) { return n >= 2 * kHugePage / sizeof(T); }
  T* allocate(std::size_t n) {
    if (!Huge(n)) return std::allocator<T>::allocate(n);
    if (n > std::allocator_traits<std::allocator<T>>::max_size(*this)) throw std::bad_alloc();
    const std::size_t bytes = (n * sizeof(T) + kHugePage - 1) / kHugePage * kHugePage;
    void* block = std::aligned_alloc(kHugePage, bytes);
    if (block == nullptr) throw std::bad_alloc();
#if defined(__linux__)
    madvise(block, bytes, MADV_HUGEPAGE);
#endif
    return static_cast<T*>(block);
  }
  void deallocate(T* block, std::size_t n) {
    if (!Huge(n)) return std::allocator<T>::deallocate(block, n);
    std::free(block);
  }
  template <typename U>
  void construct(U* at) noexcept {
    ::new (static_cast<void*>(at)) U;  // default-initialised: no store
  }
  template <typename U, typename... Args>
  void construct(U* at, Args&&... args) {
    ::new (static_cast<void*>(at)) U(std::forward<Args>(args)...);
  }
};

// The stored values of one output: deviations from the value at the estimates, one per trial.
using ValueSeries = std::vector<float, UninitializedAllocator<float>>;

// Trials per item when a pass over all the stored values of a run is shared over the threads:
// small enough that 10^6 trials give 8 items for each of 16 threads (issue 33), large enough that
// handing an item out (a few hundred ns) is lost in its work (about 10 us).
inline constexpr std::int64_t kPassChunk = std::int64_t{1} << 12;

}  // namespace vlt::mcm_internal
