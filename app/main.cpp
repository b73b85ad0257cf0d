// sigmaheart: personalise Bestel-Clement-Sorine heart models from clinical data.
// Everything lives in sigmaheart_cli (app/cli.h) so the tests can run commands in-process.
#include "app/blackbox/register.h"
#include "app/cli.h"
#include "estimation/interrupt.h"
#include "estimation/mpi.h"

#include <iostream>

int main(int argc, char** argv) {
  // Under mpirun every rank runs the same command on the world communicator (only rank 0 prints
  // and writes files; all ranks return the same exit code). MPI is initialised only when
  // compiled in; otherwise world() is a single rank.
  // SIGINT/SIGTERM only set a flag from here on (estimation/interrupt.h), also while MPI starts.
  sigmaheart::estimation::install_interrupt_handlers();
  sigmaheart::estimation::MpiSession mpi(&argc, &argv);
  // The built-in models plus the black-box ones (`model: external`, `model: umbridge`).
  return sigmaheart::app::run_cli(argc, argv, std::cout, std::cerr, mpi.world(),
                                  sigmaheart::app::blackbox::cli_models());
}
