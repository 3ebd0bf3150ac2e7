// Bare Verilator harness for the bulk wrapper (rast_bulk): no Python, no VPI.
// It reads the same cfg.hex / src.hex / regs.hex from the working directory
// as the cocotb run, clocks the model until `done`, and prints the simulated
// samples and clock cycles per wall-clock second.
//
// Built as the cocotb run is (-DRAST_BURST_CLOCK, and -CFLAGS
// -DRAST_BURST_CLOCK for this file): it toggles the wrapper's `tick`, each
// change running rast.sim.bulk.BURST_CYCLES clock cycles in one eval().
// Built with -DRAST_EXTERNAL_CLOCK instead: it toggles `clk`, two eval()s
// per clock cycle.
#include <chrono>
#include <ctime>
#include <cstdio>
#include <memory>

#include "Vrast_bulk.h"
#include "verilated.h"

int main(int argc, char** argv) {
    auto ctx = std::make_unique<VerilatedContext>();
    ctx->commandArgs(argc, argv);
    auto top = std::make_unique<Vrast_bulk>(ctx.get());
#ifdef RAST_BURST_CLOCK
    top->tick = 0;
#else
    top->clk = 0;
#endif
    top->start = 1;
    top->eval();
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    uint64_t evals = 0;
    while (!top->done && !ctx->gotFinish()) {
#ifdef RAST_BURST_CLOCK
        top->tick = !top->tick;
        top->eval();
        ++evals;
#else
        top->clk = 1;
        top->eval();
        top->clk = 0;
        top->eval();
        evals += 2;
#endif
        if (evals > (uint64_t)8e9) {
            std::fprintf(stderr, "harness: no `done` after %llu evaluations\n", (unsigned long long)evals);
            return 2;
        }
    }
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double cpu = double(std::clock() - c0) / CLOCKS_PER_SEC;
    top->final();
    const unsigned long long samples = top->in_idx;
    const unsigned long long cycles = top->cycles;
    std::printf("{\"samples\": %llu, \"cycles\": %llu, \"evals\": %llu, \"wall_s\": %.6f, "
                "\"cpu_s\": %.6f, \"samples_per_s\": %.1f, \"cycles_per_s\": %.1f}\n",
                samples, cycles, (unsigned long long)evals, s, cpu, samples / s, cycles / s);
    return 0;
}
