// mpi/ranks.cc — MPI_COMM_WORLD when built with -DVLT_MPI=ON and started by mpirun; one rank
// otherwise (docs/mpi.md).
#include "mpi/ranks.h"

#include <algorithm>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#ifdef VLT_MPI
#include <mpi.h>
#endif

#include "vlt/error.h"

namespace vlt {
namespace {

bool g_mpi = false;  // MPI_Init was called by Session
int g_rank = 0;
int g_count = 1;
bool g_agreed = false;  // a failure was agreed by Agree

#ifdef VLT_MPI
// The exit status a failure means (runtime/cli/main.cc): 2 for input and numerical errors.
bool IsUserError(const std::exception_ptr& failure) {
  try {
    std::rethrow_exception(failure);
  } catch (const InputError&) {
    return true;
  } catch (const NumericalError&) {
    return true;
  } catch (...) {
    return false;
  }
}

std::string MessageOf(const std::exception_ptr& failure) {
  try {
    std::rethrow_exception(failure);
  } catch (const std::exception& e) {
    return e.what();
  } catch (...) {
    return "unknown exception";
  }
}

// Started by an MPI launcher (Open MPI's mpirun, or a PMI/PMIx process manager)? A plain `vlt` of
// the MPI build then runs as one process without initialising MPI at all.
bool LaunchedByMpi() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK"}) {
    if (std::getenv(name) != nullptr) return true;
  }
  return false;
}

// MPI counts are int: a block larger than INT_MAX values cannot be sent in one call.
int MpiCount(std::size_t n) {
  if (n > static_cast<std::size_t>(INT_MAX)) {
    throw InputError("MPI: a block of " + std::to_string(n) +
                     " values is too large for one MPI message (at most 2^31 - 1); use fewer "
                     "points or outputs per job");
  }
  return static_cast<int>(n);
}

template <typename T>
void AllGatherImpl(std::span<const T> mine, std::span<T> all, std::span<const std::size_t> counts,
                   MPI_Datatype type) {
  std::vector<int> count(static_cast<std::size_t>(g_count)), offset(static_cast<std::size_t>(g_count));
  std::size_t total = 0;
  for (int r = 0; r < g_count; ++r) {
    count[r] = MpiCount(counts[r]);
    offset[r] = MpiCount(total);
    total += counts[r];
  }
  MpiCount(total);
  MPI_Allgatherv(mine.data(), MpiCount(mine.size()), type, all.data(), count.data(), offset.data(), type,
                 MPI_COMM_WORLD);
}
#endif

template <typename T>
void CopyOwn(std::span<const T> mine, std::span<T> all) {
  std::copy(mine.begin(), mine.end(), all.begin());
}

}  // namespace

namespace ranks {

Session::Session([[maybe_unused]] int* argc, [[maybe_unused]] char*** argv) {
#ifdef VLT_MPI
  if (!LaunchedByMpi()) return;
  int provided = 0;
  // Only the main thread calls MPI; the worker threads of each rank never do.
  MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
  g_mpi = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &g_count);
  if (g_rank != 0) {
    if (std::freopen("/dev/null", "w", stdout) == nullptr) std::fclose(stdout);
    if (std::freopen("/dev/null", "w", stderr) == nullptr) std::fclose(stderr);
  }
#endif
}

Session::~Session() {
#ifdef VLT_MPI
  if (g_mpi) MPI_Finalize();
#endif
}

int Rank() { return g_rank; }
int Count() { return g_count; }

bool FailureAgreed() { return g_agreed; }

void Agree(std::exception_ptr failure) {
  if (!g_mpi) {
    if (failure) {
      g_agreed = true;
      std::rethrow_exception(failure);
    }
    return;
  }
#ifdef VLT_MPI
  const int mine = failure ? g_rank : g_count;
  int lowest = g_count;
  MPI_Allreduce(&mine, &lowest, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  if (lowest == g_count) return;
  g_agreed = true;
  // The failure's kind and message travel from the lowest failed rank to every other.
  std::string message;
  int header[2] = {0, 0};
  if (g_rank == lowest) {
    message = MessageOf(failure);
    header[0] = IsUserError(failure) ? 1 : 0;
    header[1] = static_cast<int>(std::min<std::size_t>(message.size(), 1 << 20));
  }
  MPI_Bcast(header, 2, MPI_INT, lowest, MPI_COMM_WORLD);
  message.resize(static_cast<std::size_t>(header[1]));
  MPI_Bcast(message.data(), header[1], MPI_CHAR, lowest, MPI_COMM_WORLD);
  if (g_rank == lowest) std::rethrow_exception(failure);
  if (header[0] == 1) throw InputError(message);
  throw std::runtime_error(message);
#endif
}

}  // namespace ranks

// The exchanges of the engines (mpi/ranks.h).
namespace mpi_internal {

std::pair<int, int> ShareOf(int items, int rank) {
  const int base = items / g_count, extra = items % g_count;
  const int first = rank * base + std::min(rank, extra);
  return {first, first + base + (rank < extra ? 1 : 0)};
}

std::pair<int, int> Share(int items) { return ShareOf(items, g_rank); }

void AllGather(std::span<const double> mine, std::span<double> all, std::span<const std::size_t> counts) {
#ifdef VLT_MPI
  if (g_mpi) return AllGatherImpl(mine, all, counts, MPI_DOUBLE);
#endif
  (void)counts;
  CopyOwn(mine, all);
}

void AllGather(std::span<const float> mine, std::span<float> all, std::span<const std::size_t> counts) {
#ifdef VLT_MPI
  if (g_mpi) return AllGatherImpl(mine, all, counts, MPI_FLOAT);
#endif
  (void)counts;
  CopyOwn(mine, all);
}

void AllToAll(std::span<const float> send, std::span<const std::size_t> send_counts, std::span<float> receive,
              std::span<const std::size_t> receive_counts) {
#ifdef VLT_MPI
  if (g_mpi) {
    std::vector<int> sc(static_cast<std::size_t>(g_count)), sd(sc.size()), rc(sc.size()), rd(sc.size());
    std::size_t s_at = 0, r_at = 0;
    for (int r = 0; r < g_count; ++r) {
      sc[r] = MpiCount(send_counts[r]);
      sd[r] = MpiCount(s_at);
      rc[r] = MpiCount(receive_counts[r]);
      rd[r] = MpiCount(r_at);
      s_at += send_counts[r];
      r_at += receive_counts[r];
    }
    MPI_Alltoallv(send.data(), sc.data(), sd.data(), MPI_FLOAT, receive.data(), rc.data(), rd.data(),
                  MPI_FLOAT, MPI_COMM_WORLD);
    return;
  }
#endif
  (void)send_counts;
  (void)receive_counts;
  CopyOwn(send, receive);
}

double Max(double mine) {
#ifdef VLT_MPI
  if (g_mpi) {
    double largest = mine;
    MPI_Allreduce(&mine, &largest, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    return largest;
  }
#endif
  return mine;
}

}  // namespace mpi_internal
}  // namespace vlt
