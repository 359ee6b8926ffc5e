// mpi/ranks.h — the processes of an MPI run (`mpirun -np N vlt run|map ...`, docs/mpi.md).
//
// vlt built with -DVLT_MPI=ON splits the Monte Carlo trials of a run over the ranks of
// MPI_COMM_WORLD; rank 0 writes the outputs. Without MPI (or when the MPI build is started without
// mpirun) there is one rank and every function here is trivial, so the code that uses them reads
// the same in both builds.
//
// Failures. A rank that fails (bad input, a non-finite trial, no memory) must not leave the others
// waiting in a collective operation. Every collective step of vlt is therefore preceded by Agree():
// each rank says whether it failed; if any did, every rank throws the failure of the lowest failed
// rank and no further collective is entered. main() calls Agree once more at the end, with its own
// failure or with none, so a rank that failed anywhere meets the others at their next Agree.
#pragma once

#include <cstddef>
#include <exception>
#include <span>
#include <utility>

namespace vlt::ranks {

// MPI_Init at construction (when built with MPI), MPI_Finalize at destruction. On ranks other
// than 0 standard output and standard error go to /dev/null: rank 0 alone prints (the summary,
// warnings, the one error line).
class Session {
 public:
  Session(int* argc, char*** argv);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
};

int Rank();    // 0 without MPI
int Count();   // 1 without MPI
inline bool IsRoot() { return Rank() == 0; }

// This rank's share [first, last) of `items` work items: contiguous blocks in rank order, sizes
// differing by at most one (the first items % Count() ranks get one more).
std::pair<int, int> Share(int items);
std::pair<int, int> ShareOf(int items, int rank);   // the share of any rank

// Collective. `failure`: this rank's exception, or null. If any rank failed, every rank throws:
// the lowest failed rank its own exception, the others a copy of it (InputError for an
// InputError or NumericalError, which exit with status 2; std::runtime_error otherwise) with the
// same message; FailureAgreed() is true from then on. Without MPI: rethrows `failure`.
void Agree(std::exception_ptr failure = nullptr);
bool FailureAgreed();

// Collective: every rank contributes `mine`; `all` receives the ranks' blocks one after the other
// in rank order (block r has counts[r] values). Exact copies: no arithmetic.
void AllGather(std::span<const double> mine, std::span<double> all, std::span<const std::size_t> counts);
void AllGather(std::span<const float> mine, std::span<float> all, std::span<const std::size_t> counts);

// Collective: every rank sends send_counts[r] values to rank r (the blocks one after the other
// in `send`, in rank order) and receives receive_counts[r] values from rank r (likewise in
// `receive`). Exact copies.
void AllToAll(std::span<const float> send, std::span<const std::size_t> send_counts,
              std::span<float> receive, std::span<const std::size_t> receive_counts);

// Collective: the largest of the ranks' values (exact: no rounding in a maximum).
double Max(double mine);

}  // namespace vlt::ranks
