// vlt/mpi.h — the processes of an MPI run (`mpirun -np N vlt run|map|network ...`, docs/mpi.md), as a
// program that uses vlt's engines sees them: one Session for the life of the program, the rank and
// count, and the agreement on failures. vlt built with -DVLT_MPI=ON splits the Monte Carlo trials
// of a run over the ranks of MPI_COMM_WORLD and rank 0 writes the outputs; without MPI (or when
// the MPI build is started without mpirun) there is one rank and every function here is trivial.
//
// Failures. A rank that fails (bad input, a non-finite trial, no memory) must not leave the others
// waiting in a collective operation. Every collective step of vlt is therefore preceded by Agree():
// each rank says whether it failed; if any did, every rank throws the failure of the lowest failed
// rank and no further collective is entered. A program calls Agree once more at the end, with its
// own failure or with none, so a rank that failed anywhere meets the others at their next Agree.
#pragma once

#include <exception>

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

int Rank();   // 0 without MPI
int Count();  // 1 without MPI
inline bool IsRoot() { return Rank() == 0; }

// Collective. `failure`: this rank's exception, or null. If any rank failed, every rank throws:
// the lowest failed rank its own exception, the others a copy of it (InputError for an
// InputError or NumericalError, which exit with status 2; std::runtime_error otherwise) with the
// same message; FailureAgreed() is true from then on. Without MPI: rethrows `failure`.
void Agree(std::exception_ptr failure = nullptr);
bool FailureAgreed();

}  // namespace vlt::ranks
