// Bare Verilator harness for the bulk wrapper (rast_bulk, built with
// -DRAST_EXTERNAL_CLOCK): no Python, no VPI. It reads the same cfg.hex /
// src.hex / regs.hex from the working directory as the cocotb run, clocks the
// model until `done`, and prints the simulated samples per wall-clock second.
#include <chrono>
#include <cstdio>
#include <memory>

#include "Vrast_bulk.h"
#include "verilated.h"

int main(int argc, char** argv) {
    auto ctx = std::make_unique<VerilatedContext>();
    ctx->commandArgs(argc, argv);
    auto top = std::make_unique<Vrast_bulk>(ctx.get());
    top->clk = 0;
    top->start = 1;
    top->eval();
    const auto t0 = std::chrono::steady_clock::now();
    uint64_t edges = 0;
    while (!top->done && !ctx->gotFinish()) {
        top->clk = 1;
        top->eval();
        top->clk = 0;
        top->eval();
        ++edges;
        if (edges > (uint64_t)4e9) {
            std::fprintf(stderr, "harness: no `done` after %llu cycles\n", (unsigned long long)edges);
            return 2;
        }
    }
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    top->final();
    const unsigned long long samples = top->in_idx;
    std::printf("{\"samples\": %llu, \"cycles\": %llu, \"wall_s\": %.6f, \"samples_per_s\": %.1f, "
                "\"cycles_per_s\": %.1f}\n",
                samples, (unsigned long long)top->cycles, s, samples / s, edges / s);
    return 0;
}
