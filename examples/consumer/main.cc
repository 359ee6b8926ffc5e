// A program that uses vlt as a library (docs/library.md): it runs the demo job that `vlt demo`
// runs, GUM only, and prints the worst point and the first task — the numbers `vlt demo --no-mcm`
// prints. Built against an installed vlt with find_package(vlt) (CMakeLists.txt here) or with
// pkg-config (`c++ -std=c++20 main.cc $(pkg-config --cflags --libs vlt)`).
#include <cstdio>
#include <exception>

#include <vlt/vlt.h>  // the whole API; <vlt/job.h> and <vlt/results.h> alone would do here

int main() {
  try {
    const vlt::Job job = vlt::ParseJob(vlt::DefaultJobToml(), vlt::kDefaultJobName, ".");
    vlt::RunOptions options;
    options.monte_carlo = false;  // GUM only: quick
    const vlt::Results results = vlt::RunJob(job, options);

    // The point with the largest |U| = sqrt(Ux^2 + Uy^2 + Uz^2) (part frame, k = 1.96 per axis).
    const vlt::PointResult* worst = &results.points.front();
    for (const vlt::PointResult& p : results.points) {
      if (p.gum.U_part().norm() > worst->gum.U_part().norm()) worst = &p;
    }
    std::printf("vlt %s: job '%s', %zu points, %zu tasks\n", results.vlt_version.c_str(),
                results.job_name.c_str(), results.points.size(), results.tasks.size());
    std::printf("worst point %s: |U| = %.1f µm\n", worst->input.name.c_str(), worst->gum.U_part().norm() * 1e6);
    const vlt::TaskResult& task = results.tasks.front();
    std::printf("task %s: %s = %.6f, U = %.2f µm\n", task.spec.name.c_str(),
                task.gum.quantities.front().c_str(), task.gum.value[0], task.gum.U[0] * 1e6);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 1;
  }
}
