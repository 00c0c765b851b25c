// SPDX-License-Identifier: Apache-2.0
#pragma once

// Code placement for the decoder, which WebAssembly pages download (its size is budgeted): the
// cold functions (stream headers, frequency tables, error messages) are optimised for size where
// the compiler can (clang, which builds the WebAssembly decoder), and the hot loops are kept out
// of them, so that they are not optimised for size along with them.
#if defined(__clang__)
#define OSTEON_COLD_FUNCTION __attribute__((minsize))
#else
#define OSTEON_COLD_FUNCTION
#endif
// Before a hot loop over a point's axes or a triangle's corners: unrolled in full. The
// WebAssembly decoder is built without unrolling (-fno-unroll-loops: 0.6 KB less download, its
// cold loops rolled up), so the loops that set its speed say so themselves.
#if defined(__clang__)
#define OSTEON_UNROLL _Pragma("clang loop unroll(full)")
#else
#define OSTEON_UNROLL
#endif
#if defined(__GNUC__) || defined(__clang__)
#define OSTEON_NOINLINE __attribute__((noinline))
#else
#define OSTEON_NOINLINE
#endif
