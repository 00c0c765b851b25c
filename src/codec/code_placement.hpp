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
#if defined(__GNUC__) || defined(__clang__)
#define OSTEON_NOINLINE __attribute__((noinline))
#else
#define OSTEON_NOINLINE
#endif
