// The hot loops, compiled twice: for AVX2 and for any x86-64 (the build's -march=x86-64-v2). The
// loader picks the one the CPU runs (GCC's function multiversioning), so the Release build stays
// portable while AVX2's three-operand and wider instructions do the work where they can. FMA is
// left out on purpose: a fused multiply-add rounds differently, and the solve's choice of the next
// shooter follows the last bit of the powers, so results would depend on the processor.
//
// What a clone calls runs in the baseline ISA unless it is inlined, and GCC inlines a helper into
// a clone only if it is declared `inline` (lambdas: always_inline); its heuristics alone call the
// walk's form factor and near cells out of line.
#pragma once

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define RADIOSITY_HOT __attribute__((target_clones("avx2", "default")))
#else
#define RADIOSITY_HOT
#endif
