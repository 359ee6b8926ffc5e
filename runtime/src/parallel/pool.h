// The process's worker threads, shared by every engine (GUM fields and point lists, tasks, the
// Monte Carlo method, networks, planning, output formatting).
//
// Why one persistent pool: a GUM field of a few thousand points takes a few hundred microseconds,
// about what starting and joining threads costs; threads started per call kept two threads at
// 1.1-1.5x one thread on such fields (docs/performance.md 4). The workers here are started once,
// on the first parallel call that needs them, and wait for work between calls (spinning briefly,
// then blocking), so a call costs a wake-up, not a thread start.
//
// Determinism: items are handed out in increasing order through one counter; which thread runs an
// item never changes what the item computes, so callers that combine per-item results in item
// order get the same bits for any thread count (docs/monte-carlo.md).
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

namespace vlt::parallel_internal {

// The number of threads for a request: `requested` when positive, else the hardware concurrency
// (at least 1).
int ResolveThreads(int requested);

// Runs fn(item, worker) for every item in [0, count) on up to `threads` threads (0: hardware
// concurrency); worker is in [0, min(threads, count)) and identifies the thread for per-thread
// scratch space, the calling thread being worker 0. Returns when every item has run.
//
// An exception thrown by fn stops the handing out of further items; after the items already
// started have finished, the exception of the lowest failing item is rethrown. Since items are
// handed out in increasing order, every item below a failing one has started, so this is the
// first failing item in item order whatever the thread count.
//
// A call from inside fn (nested parallelism) runs its items on the calling thread. Calls from
// several outside threads at once are served one after the other.
void ForEach(std::size_t count, int threads, const std::function<void(std::size_t item, int worker)>& fn);

// For the tests of the work offered to the threads: while `counts` is set, the item count of every
// ForEach called from outside a parallel item (a phase of an engine) is appended to it; nullptr
// stops the recording. Not for use while other threads call ForEach.
void RecordItemCounts(std::vector<std::size_t>* counts);

// ForEach over the chunks [c * chunk, min(n, (c + 1) * chunk)) of [0, n): body(c, begin, end).
// Chunks are fixed by n and chunk alone, so results combined per chunk in chunk order do not depend
// on the thread count.
void ForEachChunk(
    std::size_t n, std::size_t chunk, int threads,
    const std::function<void(std::size_t chunk_index, std::size_t begin, std::size_t end)>& body);

}  // namespace vlt::parallel_internal
