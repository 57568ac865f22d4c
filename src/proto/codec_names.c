// SPDX-License-Identifier: MIT
/*
 * Names for codec values: protocols, error flags, run modes and the 0xB5
 * model string (the 0xB2 version date is read where the dialect is decided
 * by it, dialect.c).  Pure and rt-safe; every string returned is static.
 */
#include <errno.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "rmd/codec.h"
#include "rmd/dialect.h"

const char *rmd_proto_key(enum rmd_proto proto)
{
	const struct rmd_dialect *d = rmd_dialect(proto);

	return d ? d->key : "?";
}

const char *rmd_proto_name(enum rmd_proto proto)
{
	const struct rmd_dialect *d = rmd_dialect(proto);

	return d ? d->name : "?";
}

int rmd_proto_parse(const char *s, enum rmd_proto *proto)
{
	for (unsigned i = 0; i < RMD_PROTO_COUNT; i++) {
		const char *k = rmd_dialect((enum rmd_proto)i)->key;
		size_t j;

		/* ASCII case-insensitive, whatever the locale. */
		for (j = 0; k[j] && (s[j] == k[j] || s[j] == k[j] - 'a' + 'A'); j++)
			;
		if (!k[j] && !s[j]) {
			*proto = (enum rmd_proto)i;
			return 0;
		}
	}
	return -EINVAL;
}

/* The keys (firmware_only: the firmware dialects'), sep between two, last before the last. */
static const char *keys_text(char *buf, size_t size, const char *sep, const char *last,
			     bool firmware_only)
{
	size_t k = 0, n = 0, have = 0;

	if (!size)
		return buf;
	buf[0] = '\0';
	for (unsigned i = 0; i < RMD_PROTO_COUNT; i++)
		n += !firmware_only || rmd_dialect_is_firmware(rmd_dialect((enum rmd_proto)i));
	for (unsigned i = 0; i < RMD_PROTO_COUNT && k < size; i++) {
		const struct rmd_dialect *d = rmd_dialect((enum rmd_proto)i);
		int w;

		if (firmware_only && !rmd_dialect_is_firmware(d))
			continue;
		have++;
		w = snprintf(buf + k, size - k, "%s%s",
			     have == 1 ? "" :
			     have == n ? last :
					 sep,
			     d->key);
		if (w < 0)
			break;
		k += (size_t)w;
	}
	return buf;
}

const char *rmd_proto_keys_text(char *buf, size_t size, const char *sep, const char *last)
{
	return keys_text(buf, size, sep, last, false);
}

const char *rmd_firmware_keys_text(char *buf, size_t size, const char *sep, const char *last)
{
	return keys_text(buf, size, sep, last, true);
}

/* A bit no table names keeps a name of its own, so no flag goes unreported. */
static const char *const unknown_bits[16] = {
	"unknown_0x0001", "unknown_0x0002", "unknown_0x0004", "unknown_0x0008",
	"unknown_0x0010", "unknown_0x0020", "unknown_0x0040", "unknown_0x0080",
	"unknown_0x0100", "unknown_0x0200", "unknown_0x0400", "unknown_0x0800",
	"unknown_0x1000", "unknown_0x2000", "unknown_0x4000", "unknown_0x8000",
};

static const char *bit_name(const struct rmd_flag_name *t, size_t n, uint16_t bit)
{
	for (size_t i = 0; i < n; i++)
		if (t[i].code == bit)
			return t[i].name;
	return NULL;
}

size_t rmd_error_names(enum rmd_proto proto, uint16_t code, const char **names, size_t max)
{
	const struct rmd_dialect *d = rmd_dialect(proto);
	size_t count = 0;

	if (!d)
		return 0;
	for (size_t i = 0; i < d->n_error_codes; i++) {
		if (d->error_codes[i].code == code) {
			if (max > 0)
				names[0] = d->error_codes[i].name;
			return 1;
		}
	}
	for (unsigned b = 0; b < 16; b++) {
		uint16_t bit = (uint16_t)(1u << b);
		const char *name;

		if (!(code & bit))
			continue;
		name = bit_name(d->error_bits, d->n_error_bits, bit);
		if (count < max)
			names[count] = name ? name : unknown_bits[b];
		count++;
	}
	return count;
}

const char *rmd_run_mode_name(enum rmd_proto proto, uint8_t mode)
{
	const struct rmd_dialect *d = rmd_dialect(proto);

	for (size_t i = 0; d && i < d->n_run_modes; i++)
		if (d->run_modes[i].code == mode)
			return d->run_modes[i].name;
	return NULL;
}

/* V3 §2.32: seven ASCII bytes, data[1] first (the field's LSB). */
void rmd_model_string(int64_t raw, char buf[8])
{
	uint64_t u = (uint64_t)raw;
	unsigned n;

	for (n = 0; n < 7; n++, u >>= 8) {
		uint8_t c = (uint8_t)u;

		if (!c)
			break;
		buf[n] = (c >= 0x20 && c < 0x7F) ? (char)c : '?';
	}
	buf[n] = '\0';
}

int64_t rmd_model_raw(const char *s)
{
	uint64_t u = 0;

	if (!s)
		return 0;
	for (unsigned i = 0; i < 7 && s[i]; i++)
		u |= (uint64_t)(uint8_t)s[i] << (8 * i);
	return (int64_t)u;
}
