/* SPDX-License-Identifier: MIT */
/*
 * The simulator's deterministic PRNG: splitmix64 to turn a seed into a
 * state, xorshift64* to draw.  One seed makes a whole run reproducible.
 * Pure and rt-safe.
 */
#ifndef RMD_RNG_H
#define RMD_RNG_H

#include <stdbool.h>
#include <stdint.h>

/* A non-zero xorshift state from any seed (splitmix64). */
static inline uint64_t rmd_rng_seed(uint64_t x)
{
	x += UINT64_C(0x9E3779B97F4A7C15);
	x = (x ^ (x >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
	x = (x ^ (x >> 27)) * UINT64_C(0x94D049BB133111EB);
	x ^= x >> 31;
	return x ? x : UINT64_C(0x2545F4914F6CDD1D);
}

/* Next 64 random bits (xorshift64*); *state must be non-zero. */
static inline uint64_t rmd_rng_next(uint64_t *state)
{
	uint64_t x = *state;

	x ^= x >> 12;
	x ^= x << 25;
	x ^= x >> 27;
	*state = x;
	return x * UINT64_C(0x2545F4914F6CDD1D);
}

/* Uniform in [0, 1). */
static inline double rmd_rng_unit(uint64_t *state)
{
	return (double)(rmd_rng_next(state) >> 11) * 0x1.0p-53;
}

/* True with probability p; p >= 1 and p <= 0 (or NaN) draw nothing. */
static inline bool rmd_rng_roll(uint64_t *state, double p)
{
	if (p >= 1.0)
		return true;
	if (!(p > 0.0))
		return false;
	return rmd_rng_unit(state) < p;
}

#endif /* RMD_RNG_H */
