#include "parallel/pool.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <limits>
#include <mutex>
#include <thread>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#include <pthread.h>

namespace vlt::parallel_internal {

int ResolveThreads(int requested) {
  if (requested > 0) return requested;
  const unsigned hardware = std::thread::hardware_concurrency();
  return hardware == 0 ? 1 : static_cast<int>(hardware);
}

namespace {

// True on a thread while it runs items of a job (a worker, or the caller as worker 0): a nested
// ForEach then runs inline instead of waiting for workers that are busy with the outer job.
thread_local bool tl_inside_job = false;

// Polls of an idle worker (and of the waiting caller) before it blocks: about 20-50 us of pause
// instructions, longer than the gap between the back-to-back calls of a map or a Monte Carlo batch,
// far shorter than anything a blocked thread would be worth keeping a core for.
constexpr int kSpinPolls = 4000;

inline void CpuRelax() {
#if defined(__x86_64__) || defined(__i386__)
  _mm_pause();
#else
  std::this_thread::yield();
#endif
}

// One ForEach call.
struct Job {
  const std::function<void(std::size_t, int)>* fn = nullptr;
  std::size_t count = 0;
  std::atomic<std::size_t> next{0};
  std::mutex error_mutex;
  std::size_t failed_item = std::numeric_limits<std::size_t>::max();
  std::exception_ptr error;

  void RunItems(int worker) {
    for (;;) {
      const std::size_t item = next.fetch_add(1, std::memory_order_relaxed);
      if (item >= count) return;
      try {
        (*fn)(item, worker);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (item < failed_item) {
          failed_item = item;
          error = std::current_exception();
        }
        next.store(count, std::memory_order_relaxed);  // hand out nothing more
      }
    }
  }
};

// True in a child process forked after the workers started: they do not exist there (fork copies
// only the calling thread), so ForEach runs inline (a Python multiprocessing worker, say).
std::atomic<bool> forked_child{false};

class Pool {
 public:
  void Run(int threads, Job& job) {
    std::lock_guard<std::mutex> serve(busy_);  // one outside caller at a time
    const int helpers = threads - 1;
    while (static_cast<int>(workers_.size()) < helpers) {
      const int index = static_cast<int>(workers_.size()) + 1;
      workers_.emplace_back([this, index] { WorkerLoop(index); });
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = &job;
      active_ = helpers;
      pending_.store(helpers, std::memory_order_relaxed);
      generation_.fetch_add(1, std::memory_order_release);
    }
    wake_.notify_all();
    tl_inside_job = true;
    job.RunItems(0);
    tl_inside_job = false;
    // Wait for the helpers: spin, then block.
    for (int poll = 0; pending_.load(std::memory_order_acquire) != 0; ++poll) {
      if (poll < kSpinPolls) {
        CpuRelax();
        continue;
      }
      std::unique_lock<std::mutex> lock(mutex_);
      done_.wait(lock, [this] { return pending_.load(std::memory_order_acquire) == 0; });
      break;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = nullptr;
  }

 private:
  void WorkerLoop(int index) {
    tl_inside_job = true;  // a worker only ever runs items
    std::uint64_t seen = 0;
    for (;;) {
      // Wait for a new generation: spin, then block.
      for (int poll = 0; generation_.load(std::memory_order_acquire) == seen; ++poll) {
        if (poll < kSpinPolls) {
          CpuRelax();
          continue;
        }
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return generation_.load(std::memory_order_relaxed) != seen; });
        break;
      }
      // The job and its helper count are read together with the generation they belong to.
      Job* job = nullptr;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        seen = generation_.load(std::memory_order_relaxed);
        if (index <= active_) job = job_;
      }
      if (job == nullptr) continue;  // not needed for this job
      job->RunItems(index);
      if (pending_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
        std::lock_guard<std::mutex> lock(mutex_);  // the caller checks pending_ under this lock
        done_.notify_one();
      }
    }
  }

  std::mutex busy_;
  std::mutex mutex_;  // guards job_, active_ and the generation's updates
  std::condition_variable wake_, done_;
  std::vector<std::thread> workers_;  // worker index = position + 1 (the caller is worker 0)
  std::atomic<std::uint64_t> generation_{0};
  Job* job_ = nullptr;
  int active_ = 0;  // workers 1..active_ take part in the current job
  std::atomic<int> pending_{0};
};

// Never destroyed: the workers wait until the process ends (joining them from a static destructor
// would order them against every other static of the process and hang in a forked child).
Pool& SharedPool() {
  static Pool* const pool = [] {
    pthread_atfork(nullptr, nullptr, [] { forked_child.store(true); });
    return new Pool;
  }();
  return *pool;
}

}  // namespace

namespace {
std::atomic<std::vector<std::size_t>*> recorded_counts{nullptr};
}  // namespace

void RecordItemCounts(std::vector<std::size_t>* counts) { recorded_counts.store(counts); }

void ForEach(std::size_t count, int threads, const std::function<void(std::size_t, int)>& fn) {
  if (std::vector<std::size_t>* counts = recorded_counts.load(std::memory_order_relaxed); counts && !tl_inside_job) {
    counts->push_back(count);
  }
  Job job;
  job.fn = &fn;
  job.count = count;
  const std::size_t wanted = std::min<std::size_t>(static_cast<std::size_t>(ResolveThreads(threads)), count);
  if (wanted <= 1 || tl_inside_job || forked_child.load(std::memory_order_relaxed)) {
    job.RunItems(0);
  } else {
    SharedPool().Run(static_cast<int>(wanted), job);
  }
  if (job.error) std::rethrow_exception(job.error);
}

void ForEachChunk(std::size_t n, std::size_t chunk, int threads,
                  const std::function<void(std::size_t, std::size_t, std::size_t)>& body) {
  const std::size_t num_chunks = (n + chunk - 1) / chunk;
  ForEach(num_chunks, threads, [&](std::size_t c, int) { body(c, c * chunk, std::min(n, (c + 1) * chunk)); });
}

}  // namespace vlt::parallel_internal
