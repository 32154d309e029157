// The hot loops, compiled twice: for AVX2 and for any x86-64 (the build's -march=x86-64-v2). The
// loader picks the one the CPU runs (GCC's function multiversioning), so the Release build stays
// portable. AVX2's three-operand and wider instructions took a tenth off the instructions a draft
// solve spends outside Embree (callgrind, one thread). FMA is left out on purpose: a fused multiply-add
// rounds differently, and the solve's choice of the next shooter follows the last bit of the powers
// (with FMA a converged draft solve of the Cornell box took 689 shots instead of 610 and its
// vertices moved by up to 7%).
//
// What a clone calls runs in the baseline ISA unless it is inlined, and GCC inlines a helper into
// a clone only if it is declared `inline` (lambdas: always_inline). Left to its heuristics it
// called the walk's form factor and near cells out of line, which cost back half the gain.
#pragma once

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define RADIOSITY_HOT __attribute__((target_clones("avx2", "default")))
#else
#define RADIOSITY_HOT
#endif
