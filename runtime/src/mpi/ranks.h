// mpi/ranks.h — the collective exchanges of an MPI run (docs/mpi.md).
//
// The session, rank and count and the agreement on failures are public (vlt/mpi.h, with the
// contract); here are the exchanges the engines use, each collective preceded by Agree().
#pragma once

#include <cstddef>
#include <exception>
#include <span>
#include <utility>

#include "vlt/mpi.h"

namespace vlt::mpi_internal {

// This rank's share [first, last) of `items` work items: contiguous blocks in rank order, sizes
// differing by at most one (the first items % Count() ranks get one more).
std::pair<int, int> Share(int items);
std::pair<int, int> ShareOf(int items, int rank);  // the share of any rank

// Collective: every rank contributes `mine`; `all` receives the ranks' blocks one after the other
// in rank order (block r has counts[r] values). Exact copies: no arithmetic.
void AllGather(std::span<const double> mine, std::span<double> all, std::span<const std::size_t> counts);
void AllGather(std::span<const float> mine, std::span<float> all, std::span<const std::size_t> counts);

// Collective: every rank sends send_counts[r] values to rank r (the blocks one after the other
// in `send`, in rank order) and receives receive_counts[r] values from rank r (likewise in
// `receive`). Exact copies.
void AllToAll(std::span<const float> send, std::span<const std::size_t> send_counts, std::span<float> receive,
              std::span<const std::size_t> receive_counts);

// Collective: the largest of the ranks' values (exact: no rounding in a maximum).
double Max(double mine);

}  // namespace vlt::mpi_internal
