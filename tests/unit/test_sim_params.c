// SPDX-License-Identifier: MIT
/*
 * One table of simulator parameters (rmd/sim_params.h) for both readers:
 * every row is accepted by rmdd.yaml's sim section (rmd_config_load()) and
 * by rmd-sim (its own config code, src/tools/rmd-sim/config.c, linked in)
 * under its canonical name, its '-' spelling and its old alias, with the
 * same value; and `rmd-sim --help` names every row and its unit.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "rmd/config_yaml.h"
#include "rmd/sim_params.h"
#include "tools/rmd-sim/rmd-sim.h"
#include "harness/suite.h"

/* The programs' logger (src/tools/common/log.c) is not linked: here it collects the messages. */
static char logbuf[4096];

void tool_log(int level, const char *fmt, ...)
{
	size_t k = strlen(logbuf);
	va_list ap;

	(void)level;
	va_start(ap, fmt);
	vsnprintf(logbuf + k, sizeof(logbuf) - k, fmt, ap);
	va_end(ap);
}

void tool_log_set_level(int max_level)
{
	(void)max_level;
}

bool tool_log_enabled(int level)
{
	(void)level;
	return true;
}

static struct rmd_config cfg;
static struct rmd_sim_setup sim;
static struct sim_config sc;

/* A value of the row that is not its default, as text. */
static void sample(const struct rmd_sim_param *row, char *out, size_t size)
{
	static const char *const text[] = {
		[RMD_SIM_PARAM_PROTO] = "mit",
		[RMD_SIM_PARAM_MODEL] = "T3ST",
		[RMD_SIM_PARAM_VERSION] = "20230102",
		[RMD_SIM_PARAM_MIT] = "10,40,20,400,4",
		[RMD_SIM_PARAM_PERSONALITY] = "x8-p20-2026042402",
	};
	struct rmd_sim_motor_params d;
	const char *field;
	double v;
	unsigned u;
	bool b;

	rmd_sim_motor_params_default(&d, 1, RMD_PROTO_V3);
	field = (const char *)&d + row->off;
	switch (row->type) {
	case RMD_SIM_PARAM_REAL:
	case RMD_SIM_PARAM_US:
		memcpy(&v, field, sizeof(v));
		if (row->type == RMD_SIM_PARAM_US)
			v /= 1000.0;
		snprintf(out, size, "%.17g", v + (row->max - v) / 1024.0);
		break;
	case RMD_SIM_PARAM_UINT:
		memcpy(&u, field, sizeof(u));
		snprintf(out, size, "%u", u < row->max ? u + 1 : u - 1);
		break;
	case RMD_SIM_PARAM_BOOL:
		memcpy(&b, field, sizeof(b));
		snprintf(out, size, "%s", b ? "false" : "true");
		break;
	case RMD_SIM_PARAM_PROTO:
	case RMD_SIM_PARAM_MODEL:
	case RMD_SIM_PARAM_VERSION:
	case RMD_SIM_PARAM_MIT:
	case RMD_SIM_PARAM_PERSONALITY:
		snprintf(out, size, "%s", text[row->type]);
		break;
	}
}

/* rmd-sim's motor 1 after `name = value`; fails on a refusal. */
static const struct rmd_sim_motor_params *rmd_sim_reads(const char *name, const char *value)
{
	sim_config_init(&sc);
	logbuf[0] = '\0';
	assert_int_equal(sim_config_set(&sc, 0, "serial", "/dev/null", "test"), 0);
	if (sim_config_set(&sc, 0, name, value, "test") < 0 || sim_config_finish(&sc) < 0)
		fail_msg("rmd-sim refuses %s = %s: %s", name, value, logbuf);
	return &sc.params[0];
}

/* rmdd.yaml's motor 1 on a sim bus after `sim.motor: {key: value}`. */
static const struct rmd_sim_motor_params *yaml_reads(const char *key, const char *value)
{
	char path[] = "/tmp/rmd-test-sim-params-XXXXXX";
	static char err[4096];
	FILE *f;
	int fd, r;

	fd = mkstemp(path);
	assert_true(fd >= 0);
	f = fdopen(fd, "w");
	assert_non_null(f);
	fprintf(f,
		"buses:\n"
		"  - name: s\n"
		"    type: sim\n"
		"    sim:\n"
		"      motor: {%s: %s}\n"
		"motors:\n"
		"  - {name: m, bus: s, id: 1, protocol: mit, mode: mit}\n",
		key, value);
	fclose(f);
	r = rmd_config_load(path, &cfg, &sim, err, sizeof(err));
	unlink(path);
	if (r)
		fail_msg("rmdd.yaml refuses %s: %s: %s", key, value, err);
	return &sim.motors[0];
}

static void test_both_readers(void **state)
{
	(void)state;
	for (size_t i = 0; i < rmd_sim_n_params; i++) {
		const struct rmd_sim_param *row = &rmd_sim_params[i];
		size_t size = rmd_sim_param_size(row);
		struct rmd_sim_motor_params want, def;
		char value[64], dashed[64];

		sample(row, value, sizeof(value));
		rmd_sim_motor_params_default(&def, 1, RMD_PROTO_V3);
		want = *rmd_sim_reads(row->key, value);
		if (!memcmp((char *)&want + row->off, (char *)&def + row->off, size))
			fail_msg("%s = %s: rmd-sim kept the default", row->key, value);
		/* the '-' spelling and the alias mean the same */
		snprintf(dashed, sizeof(dashed), "%s", row->key);
		for (char *c = dashed; *c; c++)
			if (*c == '_')
				*c = '-';
		assert_memory_equal((char *)rmd_sim_reads(dashed, value) + row->off,
				    (char *)&want + row->off, size);
		if (row->alias)
			assert_memory_equal((char *)rmd_sim_reads(row->alias, value) + row->off,
					    (char *)&want + row->off, size);
		assert_ptr_equal(rmd_sim_param_find(row->key), row);
		if (row->flags & RMD_SIM_PARAM_MOTOR_KEY)
			continue; /* rmdd.yaml: the motor entry's protocol and mit */
		if (memcmp((const char *)yaml_reads(row->key, value) + row->off,
			   (char *)&want + row->off, size))
			fail_msg("%s: %s: rmdd.yaml and rmd-sim read different values", row->key,
				 value);
	}
}

/* A value out of range is refused by both, naming the key. */
static void test_both_refuse(void **state)
{
	static char err[4096];
	char path[] = "/tmp/rmd-test-sim-params-XXXXXX";
	FILE *f;
	int fd;

	(void)state;
	sim_config_init(&sc);
	logbuf[0] = '\0';
	assert_int_equal(sim_config_set(&sc, 0, "inertia_kgm2", "0", "--inertia_kgm2"), -EINVAL);
	assert_non_null(strstr(logbuf, "kg·m²"));
	fd = mkstemp(path);
	assert_true(fd >= 0);
	f = fdopen(fd, "w");
	fputs("buses:\n  - {name: s, type: sim, sim: {motor: {inertia_kgm2: 0, model: \"A B\"}}}\n"
	      "motors:\n  - {name: m, bus: s, id: 1, protocol: mit, mode: mit}\n",
	      f);
	fclose(f);
	assert_int_equal(rmd_config_load(path, &cfg, NULL, err, sizeof(err)), -EINVAL);
	unlink(path);
	assert_non_null(strstr(err, "buses[0].sim.motor.inertia_kgm2: 0 is out of range"));
	assert_non_null(strstr(err, "buses[0].sim.motor.model: \"A B\": expected 1..7 printable"));
}

/* rmd-sim --help (sim_config_help()) names every row, its unit and its alias. */
static void test_help(void **state)
{
	char path[] = "/tmp/rmd-test-sim-help-XXXXXX";
	static char text[16384];
	int fd = mkstemp(path), saved;
	FILE *f;
	size_t n;

	(void)state;
	assert_true(fd >= 0);
	fflush(stdout);
	saved = dup(STDOUT_FILENO);
	dup2(fd, STDOUT_FILENO);
	sim_config_help();
	fflush(stdout);
	dup2(saved, STDOUT_FILENO);
	close(saved);
	f = fdopen(fd, "r");
	rewind(f);
	n = fread(text, 1, sizeof(text) - 1, f);
	text[n] = '\0';
	fclose(f);
	unlink(path);
	for (size_t i = 0; i < rmd_sim_n_params; i++) {
		const struct rmd_sim_param *row = &rmd_sim_params[i];
		char want[128];
		const char *at;

		char entry[512];
		const char *end;

		snprintf(want, sizeof(want), "--%s VALUE", row->key);
		at = strstr(text, want);
		if (!at)
			fail_msg("--help does not name %s:\n%s", row->key, text);
		/* the row's own entry: up to the next option */
		end = strstr(at, "\n  --"); /* at starts with "--", never with a newline */
		n = end ? (size_t)(end - at) : strlen(at);
		snprintf(entry, sizeof(entry), "%.*s", (int)n, at);
		at = entry;
		if (*row->unit && !strstr(at, row->unit))
			fail_msg("--help gives %s without its unit %s", row->key, row->unit);
		snprintf(want, sizeof(want), "(alias: --%s)", row->alias ? row->alias : "");
		if (row->alias && !strstr(at, want))
			fail_msg("--help gives %s without its alias %s", row->key, row->alias);
	}
}

SUITE_MAIN("sim_params", NULL, NULL,
	   {
		   cmocka_unit_test(test_both_readers),
		   cmocka_unit_test(test_both_refuse),
		   cmocka_unit_test(test_help),
	   })
