// SPDX-License-Identifier: MIT
/*
 * rmdctl end to end: runs the built binary ($RMDCTL, else $BUILD/rmdctl,
 * else build/rmdctl) on tests/data/candump-sample.log ($RMDCTL_TESTDATA
 * overrides the folder) and on encode commands, and checks stdout, stderr
 * and exit statuses.  JSON lines are checked by substrings and, when python3
 * exists, parsed by Python's json module.
 */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <poll.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "harness/json.h"
#include "harness/proc.h"

static char rmdctl[4096];
static char sample[4096];

/* Run rmdctl with args (NULL-terminated) and `len` bytes of stdin. */
static void run_argv_n(struct run *r, const char *input, size_t len, const char *const *args)
{
	run_prog(r, rmdctl, args, &(struct run_opts){ .input = input, .input_len = len });
}

/* Run rmdctl with args (NULL-terminated) and stdin text (NULL: empty). */
static void run_argv(struct run *r, const char *input, const char *const *args)
{
	run_argv_n(r, input, input ? strlen(input) : 0, args);
}

#define RUN(r, input, ...) run_argv((r), (input), (const char *const[]){ __VA_ARGS__, NULL })

static int setup(void **state)
{
	const char *data = getenv("RMDCTL_TESTDATA");

	(void)state;
	snprintf(sample, sizeof(sample), "%s/candump-sample.log",
		 data && *data ? data : "tests/data");
	if (find_prog(rmdctl, sizeof(rmdctl), "RMDCTL", "rmdctl") < 0)
		return -1;
	if (access(sample, R_OK) != 0) {
		print_error("test data \"%s\" not found (run from the repository root)\n", sample);
		return -1;
	}
	return 0;
}

/* ---- decode --------------------------------------------------------------------------- */

struct json_expect {
	const char *raw; /* finds the line */
	const char *has[8];
};

static const struct json_expect sample_json[] = {
	{ "\"raw\":\"9A00000000000000\"",
	  { "\"can_id\":321,", "\"motor_id\":1,", "\"direction\":\"request\"", "\"cmd\":154,",
	    "\"name\":\"read_status_1\"", "\"interface\":\"can0\"" } },
	/* V3 §2.12.4 */
	{ "\"raw\":\"9A320001E5010400\"",
	  { "{\"can_id\":577,\"motor_id\":1,\"direction\":\"reply\",\"cmd\":154,"
	    "\"name\":\"read_status_1\",\"raw\":\"9A320001E5010400\"",
	    "\"temperature_c\":50,", "\"voltage_v\":48.5,", "\"brake_released\":true",
	    "\"error_code\":4,", "\"errors\":[\"low_voltage\"]" } },
	/* V3 §2.17.4 example 1 */
	{ "\"raw\":\"A100000064000000\"",
	  { "\"name\":\"torque\"", "\"current_a\":1", "\"direction\":\"request\"",
	    "\"timestamp\":1700000000.000000", "\"interface\":\"can0\"" } },
	{ "\"raw\":\"A1326400F4012D00\"",
	  { "\"temperature_c\":50,", "\"current_a\":1,", "\"speed_dps\":500,", "\"angle_deg\":45",
	    "\"timestamp\":1700000000.000412" } },
	/* V3 §2.18.4 example 2, lowercase on input */
	{ "\"raw\":\"A2000000F0D8FFFF\"", { "\"name\":\"speed\"", "\"speed_dps\":-100" } },
	{ "\"raw\":\"A2329CFF0CFED3FF\"",
	  { "\"current_a\":-1,", "\"speed_dps\":-500,", "\"angle_deg\":-45" } },
	/* V3 §2.20.4 example 1, candump -td */
	{ "\"raw\":\"A400F401A08C0000\"",
	  { "\"cmd\":164,", "\"max_speed_dps\":500", "\"angle_deg\":360",
	    "\"timestamp\":0.000123" } },
	/* V3 §2.32.4, §2.29.4, §2.23.4, §2.24.4, §2.11.4, §2.30.4 */
	{ "\"raw\":\"B558385332563130\"", { "\"model\":\"X8S2V10\"" } },
	{ "\"raw\":\"B20000002E893401\"", { "\"version_date\":20220206" } },
	{ "\"raw\":\"7000000000000003\"", { "\"mode\":3," } },
	{ "\"raw\":\"710000000000D007\"", { "\"power_w\":200" } },
	{ "\"raw\":\"92000000A08C0000\"", { "\"angle_deg\":360" } },
	{ "\"raw\":\"B3000000E8030000\"", { "\"timeout_ms\":1000", "\"direction\":\"reply\"" } },
	/* V3 §5.4 */
	{ "\"raw\":\"E66682E052333B55\"",
	  { "\"can_id\":1025,", "\"motor_id\":1,", "\"direction\":\"request\"", "\"cmd\":null",
	    "\"name\":\"mit\"", "\"kd\":1,", "\"torque_nm\":10.004" } },
	{ "\"raw\":\"01E66682EB550000\"",
	  { "\"can_id\":1281,", "\"direction\":\"reply\"", "\"name\":\"mit\"",
	    "\"torque_nm\":10.004", "\"timestamp\":1700000001.000000" } },
	/* Unknown command, unknown identifier, broadcast, echo. */
	{ "\"raw\":\"C700000000000000\"", { "\"name\":\"unknown\"", "\"cmd\":199," } },
	{ "\"raw\":\"1122334455667788\"",
	  { "\"can_id\":291,", "\"motor_id\":null", "\"name\":\"unknown\"" } },
	{ "\"can_id\":640,",
	  { "\"name\":\"motor_off\"", "\"motor_id\":0,", "\"broadcast\":true" } },
	{ "\"can_id\":578,",
	  { "\"name\":\"motor_off\"", "\"motor_id\":2,", "\"direction\":\"reply\"" } },
};

/* Frames in the sample that parse; the other five lines are malformed. */
#define SAMPLE_FRAMES 19

static void test_decode_json_sample(void **state)
{
	struct run r;
	char line[1024];

	(void)state;
	RUN(&r, NULL, "decode", "--json", sample);
	assert_int_equal(r.status, 1);
	assert_int_equal(count_lines(r.out), SAMPLE_FRAMES);
	for (size_t i = 0; i < sizeof(sample_json) / sizeof(sample_json[0]); i++) {
		const struct json_expect *e = &sample_json[i];

		line_with(r.out, e->raw, line, sizeof(line));
		for (size_t j = 0; j < 8 && e->has[j]; j++)
			assert_has(line, e->has[j], e->raw);
	}
	/* MIT values by number: the codes are exact, the decimals are not. */
	line_with(r.out, "\"raw\":\"E66682E052333B55\"", line, sizeof(line));
	assert_true(fabs(json_num(line, "position_rad") - 10.0) < 1e-3);
	assert_true(fabs(json_num(line, "velocity_rad_s") - 1.021) < 1e-2);
	assert_true(fabs(json_num(line, "kp") - 10.012) < 1e-3);
	/* No line lacks a key, none has an interface it did not have. */
	line_with(r.out, "\"raw\":\"A2000000F0D8FFFF\"", line, sizeof(line));
	assert_lacks(line, "interface", "bare line");
	assert_lacks(line, "timestamp", "bare line");
	run_free(&r);
}

static void test_decode_errors(void **state)
{
	struct run r;

	(void)state;
	RUN(&r, NULL, "decode", "--json", sample);
	assert_int_equal(r.status, 1);
	assert_has(r.err, "rmdctl decode: line 19: bad hex byte \"ZZ\"\n", "stderr");
	assert_has(r.err, "rmdctl decode: line 20: truncated", "stderr");
	assert_has(r.err, "rmdctl decode: line 21: missing '#'", "stderr");
	assert_has(r.err, "rmdctl decode: line 22: DLC greater than 8 \"[9]\"", "stderr");
	assert_has(r.err, "rmdctl decode: line 23: CAN id too large", "stderr");
	assert_int_equal(count_lines(r.err), 5);
	run_free(&r);
}

static void test_decode_text(void **state)
{
	struct run r;

	(void)state;
	RUN(&r, NULL, "decode", sample);
	assert_int_equal(r.status, 1);
	assert_int_equal(count_lines(r.out), SAMPLE_FRAMES);
	ASSERT_HAS_ALL(r.out, "text",
		       "can0 241 motor 1 reply read_status_1: temperature 50 °C, brake released, "
		       "voltage 48.5 V, errors 0x0004 (low_voltage)\n",
		       "141 motor 1 request speed: speed -100 dps\n", "model \"X8S2V10\"",
		       "can0 141 motor 1 request unknown", "C7 00 00 00 00 00 00 00\n",
		       "401 motor 1 request mit: position ");
	run_free(&r);
}

static void test_decode_stdin(void **state)
{
	struct run r;

	(void)state;
	RUN(&r, "# comment\n\n   \n241#9A320001E5010400\n  # indented comment\n", "decode",
	    "--json");
	assert_int_equal(r.status, 0);
	assert_int_equal(count_lines(r.out), 1);
	assert_has(r.out, "\"voltage_v\":48.5", "stdin");
	assert_string_equal(r.err, "");
	run_free(&r);

	RUN(&r, "241#9A320001E5010400", "decode", "--json", "-"); /* no final newline */
	assert_int_equal(r.status, 0);
	assert_int_equal(count_lines(r.out), 1);
	run_free(&r);

	RUN(&r, "", "decode");
	assert_int_equal(r.status, 0);
	assert_string_equal(r.out, "");
	run_free(&r);
}

static void test_decode_long_line(void **state)
{
	char input[2048];
	struct run r;

	(void)state;
	memset(input, 'A', 1500);
	snprintf(input + 1500, sizeof(input) - 1500, "\n241#9A320001E5010400\n");
	RUN(&r, input, "decode", "--json");
	assert_int_equal(r.status, 1);
	assert_has(r.err, "rmdctl decode: line 1: longer than", "long line");
	assert_int_equal(count_lines(r.out), 1);
	assert_has(r.out, "\"temperature_c\":50", "after a long line");
	run_free(&r);
}

static void test_decode_nul_and_binary(void **state)
{
	static const char junk[] = "\x01\x02\xff\xfe#\x7f\n241#9A32\0\n241#9A320001E5010400\n";
	struct run r;

	(void)state;
	run_argv_n(&r, junk, sizeof(junk) - 1, (const char *const[]){ "decode", "--json", NULL });
	assert_int_equal(r.status, 1);
	assert_has(r.err, "rmdctl decode: line 1: bad CAN id \"\\x01\\x02\\xFF\\xFE\"", "binary");
	assert_has(r.err, "rmdctl decode: line 2: contains a NUL byte", "NUL");
	assert_int_equal(count_lines(r.out), 1);
	assert_has(r.out, "\"voltage_v\":48.5", "binary");
	run_free(&r);
}

static void test_decode_mit_ranges(void **state)
{
	char line[1024];
	struct run r;

	(void)state;
	/* t_ff code 2901 over ±18 N·m: -18 + 2901 * 36 / 4095 = 7.5033 */
	RUN(&r, "401#E66682E052333B55\n", "decode", "--json", "--mit-ranges", "12.5,45,18,500,5");
	assert_int_equal(r.status, 0);
	line_with(r.out, "\"name\":\"mit\"", line, sizeof(line));
	assert_true(fabs(json_num(line, "torque_nm") - 7.5033) < 1e-3);
	run_free(&r);

	RUN(&r, "", "decode", "--mit-ranges", "1,2,3");
	assert_int_equal(r.status, 2);
	run_free(&r);
	RUN(&r, "", "decode", "--mit-ranges", "1,2,3,4,-5");
	assert_int_equal(r.status, 2);
	run_free(&r);
	/* F1 (fuzz_mit): a range this wide decoded positions to infinity ("null") */
	RUN(&r, "501#01FFFE8008000000\n", "decode", "--protocol", "mit", "--mit-ranges",
	    "1e305,45,24,500,5");
	assert_int_equal(r.status, 2);
	assert_has(r.err, "each at most 1e+06", "rmdctl decode --mit-ranges 1e305,...");
	run_free(&r);
}

static void test_decode_v2_and_direction(void **state)
{
	char line[1024];
	struct run r;

	(void)state;
	RUN(&r, "141#9A00000000000000\n141#9A320000E5010400\n280#64009CFFC8000000\n", "decode",
	    "--json", "--protocol", "v2");
	assert_int_equal(r.status, 0);
	line_with(r.out, "\"raw\":\"9A00000000000000\"", line, sizeof(line));
	assert_has(line, "\"direction\":\"request\"", "v2 request");
	line_with(r.out, "\"raw\":\"9A320000E5010400\"", line, sizeof(line));
	assert_has(line, "\"direction\":\"reply\"", "v2 reply");
	assert_has(line, "\"voltage_v\":48.5", "v2 reply");
	assert_has(line, "\"errors\":[\"low_voltage\"]", "v2 reply");
	line_with(r.out, "\"can_id\":640", line, sizeof(line));
	assert_has(line, "\"cmd\":null", "v2 multi torque");
	assert_true(fabs(json_num(line, "current_1_a") - 1.6) < 1e-9);
	assert_true(fabs(json_num(line, "current_2_a") + 1.6) < 1e-9);
	run_free(&r);

	/* --direction forces V2's shared identifiers one way; a V3 reply id cannot be a request. */
	RUN(&r, "141#9A00000000000000\n", "decode", "--json", "--protocol", "v2", "--direction",
	    "reply");
	assert_int_equal(r.status, 0);
	assert_has(r.out, "\"direction\":\"reply\"", "forced");
	run_free(&r);
	RUN(&r, "241#9A320001E5010400\n", "decode", "--json", "--direction", "request");
	assert_int_equal(r.status, 0);
	assert_has(r.out, "\"name\":\"unknown\"", "contradiction");
	run_free(&r);
}

/* V4.2's worked example replies under --protocol v4: float gains, indexes, new commands. */
static void test_decode_v4(void **state)
{
	char line[1024];
	struct run r;

	(void)state;
	RUN(&r,
	    "241#300100000000803F\n241#310100000000C03F\n241#4201000010270000\n"
	    "241#90003308BE2C8B24\n241#9400000000001027\n241#A6326400F401E803\n"
	    "141#B660010100000000\n241#9A320001E5010048\n141#A300000064000000\n",
	    "decode", "--json", "--protocol", "v4");
	assert_int_equal(r.status, 0);
	/* §2.1.5: 0x3F800000 = 1.0; §2.2.5: 0x3FC00000 = 1.5 */
	line_with(r.out, "\"raw\":\"300100000000803F\"", line, sizeof(line));
	assert_has(line, "\"name\":\"read_pid\",", "0x30");
	assert_has(line, "\"index\":1,\"gain\":1}", "0x30");
	line_with(r.out, "\"raw\":\"310100000000C03F\"", line, sizeof(line));
	assert_has(line, "\"gain\":1.5}", "0x31");
	/* §2.4.5 example 2 */
	line_with(r.out, "\"raw\":\"4201000010270000\"", line, sizeof(line));
	assert_has(line, "\"index\":1,\"accel_dps2\":10000}", "0x42");
	/* §2.11.4 */
	line_with(r.out, "\"raw\":\"90003308BE2C8B24\"", line, sizeof(line));
	assert_has(line, "\"encoder\":2099,\"encoder_raw\":11454,\"encoder_offset\":9355", "0x90");
	/* §2.13.4: 100 deg */
	line_with(r.out, "\"raw\":\"9400000000001027\"", line, sizeof(line));
	assert_has(line, "\"angle_deg\":100}", "0x94");
	/* §2.22.4: the reply carries the encoder */
	line_with(r.out, "\"raw\":\"A6326400F401E803\"", line, sizeof(line));
	assert_has(line, "\"name\":\"position_single\"", "0xA6");
	assert_has(line, "\"encoder\":1000", "0xA6");
	/* §2.33.4: 0x60 every 10 ms */
	line_with(r.out, "\"raw\":\"B660010100000000\"", line, sizeof(line));
	assert_has(line, "\"report_command\":96,\"report_enable\":1,\"report_interval_ms\":10",
		   "0xB6");
	/* V4.3's bits (unverified): 0x4800 */
	line_with(r.out, "\"raw\":\"9A320001E5010048\"", line, sizeof(line));
	assert_has(line, "\"component_over_temperature\"", "0x9A");
	assert_has(line, "\"encoder_data_error\"", "0x9A");
	/* §9 (V3.7): 0xA3 removed */
	line_with(r.out, "\"raw\":\"A300000064000000\"", line, sizeof(line));
	assert_has(line, "\"name\":\"unknown\"", "0xA3");
	run_free(&r);
	/* the same 0x30 reply under v3 is six uint8 gains */
	RUN(&r, "241#300100000000803F\n", "decode", "--json");
	assert_int_equal(r.status, 0);
	assert_has(r.out, "\"position_kp\":128", "v3 0x30");
	run_free(&r);
	/* §4.3-4.4: asked as replies, a write's echo carries its ID at D7, a read's 0x240 + ID */
	RUN(&r, "300#7900000000000002\n300#7900010000004202\n", "decode", "--json", "--protocol",
	    "v4", "--direction", "reply");
	assert_int_equal(r.status, 0);
	line_with(r.out, "\"raw\":\"7900000000000002\"", line, sizeof(line));
	assert_has(line, "\"read_flag\":0,\"can_id_value\":2}", "0x79 write reply");
	line_with(r.out, "\"raw\":\"7900010000004202\"", line, sizeof(line));
	assert_has(line, "\"read_flag\":1,\"can_id_value\":578}", "0x79 read reply");
	run_free(&r);
}

/* Every line of --json output is a JSON object Python's parser accepts. */
static void test_decode_json_valid(void **state)
{
	char cmd[sizeof(rmdctl) + sizeof(sample) + 512];
	int rc;

	(void)state;
	if (system("command -v python3 >/dev/null 2>&1") != 0) {
		print_message("SKIPPED: python3 not found, JSON validity not checked\n");
		skip();
	}
	snprintf(cmd, sizeof(cmd),
		 "'%s' decode --json '%s' 2>/dev/null | python3 -c '"
		 "import json, sys\n"
		 "n = 0\n"
		 "for line in sys.stdin:\n"
		 "    assert isinstance(json.loads(line), dict), line\n"
		 "    n += 1\n"
		 "sys.exit(0 if n == %d else 1)'",
		 rmdctl, sample, SAMPLE_FRAMES);
	rc = system(cmd);
	assert_int_equal(rc, 0);
}

/* ---- encode --------------------------------------------------------------------------- */

struct enc_vector {
	const char *name;
	const char *args[10];
	const char *out; /* stdout, or NULL when refused */
	int status;
};

static const struct enc_vector enc[] = {
	{ "V3 §2.17.4 ex 1", { "--id", "1", "torque", "1.0" }, "141#A100000064000000\n", 0 },
	{ "V3 §2.17.4 ex 2", { "--id", "1", "torque", "-1" }, "141#A10000009CFF0000\n", 0 },
	{ "V3 §2.18.4 ex 1", { "--id", "1", "speed", "100" }, "141#A200000010270000\n", 0 },
	{ "V3 §2.18.4 ex 2", { "--id", "1", "speed", "-100" }, "141#A2000000F0D8FFFF\n", 0 },
	{ "V3 §2.19.4", { "--id", "1", "position-track", "1" }, "141#A300000064000000\n", 0 },
	{ "V3 §2.20.4 ex 1",
	  { "--id", "1", "position", "360", "500" },
	  "141#A400F401A08C0000\n",
	  0 },
	{ "V3 §2.20.4 ex 2",
	  { "--id", "1", "position", "-360", "500" },
	  "141#A400F4016073FFFF\n",
	  0 },
	{ "V3 §2.21.4",
	  { "--id", "1", "position-track-limited", "1", "50" },
	  "141#A500881364000000\n",
	  0 },
	{ "V3 §2.22.4", { "--id", "1", "increment", "-360", "500" }, "141#A800F4016073FFFF\n", 0 },
	{ "V3 §2.30.4", { "--id", "1", "timeout", "1000" }, "141#B3000000E8030000\n", 0 },
	{ "V3 §2.5.5", { "--id", "1", "accel", "0", "10000" }, "141#4300000010270000\n", 0 },
	{ "V3 §2.12.4", { "--id", "1", "status1" }, "141#9A00000000000000\n", 0 },
	{ "off motor 2", { "--id", "2", "off" }, "142#8000000000000000\n", 0 },
	{ "model motor 32", { "--id", "32", "model" }, "160#B500000000000000\n", 0 },
	{ "V3 §5.4",
	  { "--id", "1", "mit", "10", "1.021", "10", "1", "10" },
	  "401#E66682E052333B55\n",
	  0 },
	{ "mit protocol",
	  { "--protocol", "mit", "--id", "1", "mit", "10", "1.021", "10", "1", "10" },
	  "401#E66682E052333B55\n",
	  0 },
	{ "raw by byte",
	  { "--id", "1", "raw", "0xA1", "current_a=1" },
	  "141#A100000064000000\n",
	  0 },
	{ "raw by name",
	  { "--id", "1", "raw", "torque", "current_a=-1" },
	  "141#A10000009CFF0000\n",
	  0 },
	{ "V2 multi torque",
	  { "--protocol", "v2", "multi-torque", "1.6", "-1.6", "3.2", "0" },
	  "280#64009CFFC8000000\n",
	  0 },
	{ "V2 position",
	  { "--protocol", "v2", "--id", "1", "position", "360" },
	  "141#A3000000A08C0000\n",
	  0 },
	{ "V2 position limited",
	  { "--protocol", "v2", "--id", "1", "position", "360", "500" },
	  "141#A400F401A08C0000\n",
	  0 },
	{ "V2 run", { "--protocol", "v2", "--id", "1", "run" }, "141#8800000000000000\n", 0 },
	/* V4.2's worked examples (rmd-servo-protocol-v4.2-en.txt) */
	{ "V4 §2.1.5",
	  { "--protocol", "v4", "--id", "1", "pid-read", "current-kp" },
	  "141#3001000000000000\n",
	  0 },
	{ "V4 §2.2.5",
	  { "--protocol", "v4", "--id", "1", "pid", "current-kp", "1.5" },
	  "141#310100000000C03F\n",
	  0 },
	{ "V4 §2.3.5",
	  { "--protocol", "v4", "--id", "1", "pid-rom", "current-kp", "1.5" },
	  "141#320100000000C03F\n",
	  0 },
	{ "V4 pid position kd 1.0",
	  { "--protocol", "V4", "--id", "1", "pid", "position_kd", "1" },
	  "141#310900000000803F\n",
	  0 },
	{ "V4 §2.4.5 ex 1",
	  { "--protocol", "v4", "--id", "1", "accel-read", "0" },
	  "141#4200000000000000\n",
	  0 },
	{ "V4 §2.4.5 ex 2",
	  { "--protocol", "v4", "--id", "1", "accel-read", "1" },
	  "141#4201000000000000\n",
	  0 },
	{ "V4 §2.5.5 ex 4",
	  { "--protocol", "v4", "--id", "1", "accel", "3", "10000" },
	  "141#4303000010270000\n",
	  0 },
	{ "V4 §2.11.4",
	  { "--protocol", "v4", "--id", "1", "read-encoder-single" },
	  "141#9000000000000000\n",
	  0 },
	{ "V4 §2.13.4",
	  { "--protocol", "v4", "--id", "1", "read-angle-single" },
	  "141#9400000000000000\n",
	  0 },
	{ "V4 §2.20.4 ex 2",
	  { "--protocol", "v4", "--id", "1", "speed", "-100" },
	  "141#A2000000F0D8FFFF\n",
	  0 },
	{ "V4 §2.21.4 ex 1",
	  { "--protocol", "v4", "--id", "1", "position", "360", "500" },
	  "141#A400F401A08C0000\n",
	  0 },
	{ "V4 §2.22.4 ex 1",
	  { "--protocol", "v4", "--id", "1", "position-single", "360", "500", "0" },
	  "141#A600F401A08C0000\n",
	  0 },
	{ "V4 §2.22.4 ex 2",
	  { "--protocol", "v4", "--id", "1", "position-single", "360", "500", "1" },
	  "141#A601F401A08C0000\n",
	  0 },
	{ "V4 §2.23.4 ex 2",
	  { "--protocol", "v4", "--id", "1", "increment", "-360", "500" },
	  "141#A800F4016073FFFF\n",
	  0 },
	{ "V4 §2.33.4",
	  { "--protocol", "v4", "--id", "1", "active-reply", "60", "1", "10" },
	  "141#B660010100000000\n",
	  0 },
	{ "V4 active reply off",
	  { "--protocol", "v4", "--id", "1", "active-reply", "9C", "0", "0" },
	  "141#B69C000000000000\n",
	  0 },
	{ "V4 §2.34.5 ex 1",
	  { "--protocol", "v4", "--id", "1", "function", "1", "0" },
	  "141#2001000000000000\n",
	  0 },
	{ "V4 §2.34.5 ex 2",
	  { "--protocol", "v4", "--id", "1", "function", "2", "1" },
	  "141#2002000001000000\n",
	  0 },
	{ "V4 set id 5 (§2.34.4)",
	  { "--protocol", "v4", "--id", "1", "function", "5", "5" },
	  "141#2005000005000000\n",
	  0 },
	{ "V4 negative limit (§2.34.4)",
	  { "--protocol", "v4", "--id", "1", "function", "7", "-9000" },
	  "141#20070000D8DCFFFF\n",
	  0 },
	{ "V4 raw gain",
	  { "--protocol", "v4", "--id", "1", "raw", "write_pid_rom", "index=4", "gain=0.5" },
	  "141#320400000000003F\n",
	  0 },
	/* Refusals. */
	{ "no id", { "torque", "1" }, NULL, 2 },
	{ "id 0", { "--id", "0", "torque", "1" }, NULL, 2 },
	{ "id 33", { "--id", "33", "torque", "1" }, NULL, 2 },
	{ "id junk", { "--id", "1x", "torque", "1" }, NULL, 2 },
	{ "no command", { "--id", "1" }, NULL, 2 },
	{ "unknown command", { "--id", "1", "spin" }, NULL, 2 },
	{ "not a number", { "--id", "1", "torque", "one" }, NULL, 2 },
	{ "nan", { "--id", "1", "torque", "nan" }, NULL, 2 },
	{ "too many args", { "--id", "1", "torque", "1", "2" }, NULL, 2 },
	{ "too few args", { "--id", "1", "speed" }, NULL, 2 },
	{ "torque too large", { "--id", "1", "torque", "400" }, NULL, 2 },
	{ "speed too large", { "--id", "1", "speed", "1e300" }, NULL, 2 },
	{ "negative timeout", { "--id", "1", "timeout", "-1" }, NULL, 2 },
	{ "max speed too large", { "--id", "1", "position", "0", "70000" }, NULL, 2 },
	{ "accel index", { "--id", "1", "accel", "7", "1000" }, NULL, 2 },
	{ "V3 position without limit", { "--id", "1", "position", "90" }, NULL, 2 },
	{ "mit out of range", { "--id", "1", "mit", "13", "0", "0", "0", "0" }, NULL, 2 },
	{ "mit negative kp", { "--id", "1", "mit", "0", "0", "-1", "0", "0" }, NULL, 2 },
	{ "mit under V2",
	  { "--protocol", "v2", "--id", "1", "mit", "0", "0", "0", "0", "0" },
	  NULL,
	  2 },
	{ "multi torque under V3", { "multi-torque", "1", "2", "3", "4" }, NULL, 2 },
	{ "V2 torque over 32 A", { "--protocol", "v2", "--id", "1", "torque", "33" }, NULL, 2 },
	{ "V2 model", { "--protocol", "v2", "--id", "1", "model" }, NULL, 2 },
	{ "bad protocol", { "--protocol", "v9", "--id", "1", "stop" }, NULL, 2 },
	{ "V4 has no 0xA3 (V4.2 §9)",
	  { "--protocol", "v4", "--id", "1", "position-track", "1" },
	  NULL,
	  2 },
	{ "V4 has no 0x71", { "--protocol", "v4", "--id", "1", "power" }, NULL, 2 },
	{ "V4 pid-read needs LOOP", { "--protocol", "v4", "--id", "1", "pid-read" }, NULL, 2 },
	{ "V4 no gain index 3",
	  { "--protocol", "v4", "--id", "1", "pid", "current-kd", "1" },
	  NULL,
	  2 },
	{ "V4 gain nan", { "--protocol", "v4", "--id", "1", "pid", "speed-kp", "nan" }, NULL, 2 },
	{ "V4 gain beyond float",
	  { "--protocol", "v4", "--id", "1", "pid", "speed-kp", "1e39" },
	  NULL,
	  2 },
	{ "V3 pid write", { "--id", "1", "pid", "speed-kp", "1" }, NULL, 2 },
	{ "V4 function index 8",
	  { "--protocol", "v4", "--id", "1", "function", "8", "0" },
	  NULL,
	  2 },
	{ "V3 function index 5", { "--id", "1", "function", "5", "2" }, NULL, 2 },
	{ "V4 single turn 361",
	  { "--protocol", "v4", "--id", "1", "position-single", "361", "500", "0" },
	  NULL,
	  2 },
	{ "V4 single turn dir 2",
	  { "--protocol", "v4", "--id", "1", "position-single", "1", "500", "2" },
	  NULL,
	  2 },
	{ "V4 active reply of 0x9B",
	  { "--protocol", "v4", "--id", "1", "active-reply", "9B", "1", "10" },
	  NULL,
	  2 },
	{ "V4 active reply on 2",
	  { "--protocol", "v4", "--id", "1", "active-reply", "9A", "2", "10" },
	  NULL,
	  2 },
	{ "V3 active reply", { "--id", "1", "active-reply", "9A", "1", "10" }, NULL, 2 },
	{ "V4 accel-read index 4", { "--protocol", "v4", "--id", "1", "accel-read", "4" }, NULL, 2 },
	{ "raw bad field", { "--id", "1", "raw", "0xA1", "speed_dps=1" }, NULL, 2 },
	{ "raw bad cmd", { "--id", "1", "raw", "zz" }, NULL, 2 },
};

static void test_encode(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(enc) / sizeof(enc[0]); i++) {
		const struct enc_vector *v = &enc[i];
		const char *args[12] = { "encode" };
		struct run r;
		size_t n = 1;

		for (; n < 11 && v->args[n - 1]; n++)
			args[n] = v->args[n - 1];
		args[n] = NULL;
		run_argv(&r, NULL, args);
		if (r.status != v->status)
			fail_msg("%s: exit %d, want %d; stderr:\n%s", v->name, r.status, v->status,
				 r.err);
		if (v->out && strcmp(r.out, v->out))
			fail_msg("%s: printed \"%s\", want \"%s\"", v->name, r.out, v->out);
		if (!v->out && (r.out[0] || !r.err[0]))
			fail_msg("%s: refusal printed \"%s\" on stdout, \"%s\" on stderr", v->name,
				 r.out, r.err);
		run_free(&r);
	}
}

static void test_encode_messages(void **state)
{
	struct run r;

	(void)state;
	RUN(&r, NULL, "encode", "--id", "1", "torque", "400");
	assert_has(r.err, "out of range", "torque 400");
	assert_has(r.err, "current_a", "torque 400");
	run_free(&r);
	RUN(&r, NULL, "encode", "--id", "1", "mit", "0", "50", "0", "0", "0");
	assert_has(r.err, "velocity 50 rad/s is out of range", "mit");
	run_free(&r);
	RUN(&r, NULL, "encode", "torque", "1");
	assert_has(r.err, "--id", "no id");
	assert_has(r.err, "usage: rmdctl encode", "no id");
	run_free(&r);
}

/* encode | decode: what comes out is what went in. */
static void test_encode_decode_round_trip(void **state)
{
	struct run e, d;
	char line[1024];

	(void)state;
	RUN(&e, NULL, "encode", "--id", "7", "position-track-limited", "-12.34", "56.78");
	assert_int_equal(e.status, 0);
	RUN(&d, e.out, "decode", "--json");
	assert_int_equal(d.status, 0);
	line_with(d.out, "\"name\"", line, sizeof(line));
	assert_has(line, "\"motor_id\":7,", "round trip");
	assert_has(line, "\"angle_deg\":-12.34", "round trip");
	assert_has(line, "\"max_speed_dps\":56.78", "round trip");
	run_free(&e);
	run_free(&d);
	/* V4: a float gain goes out and comes back as the nearest binary32 */
	RUN(&e, NULL, "encode", "--protocol", "v4", "--id", "3", "pid-rom", "speed-ki", "0.25");
	assert_int_equal(e.status, 0);
	RUN(&d, e.out, "decode", "--json", "--protocol", "v4");
	assert_int_equal(d.status, 0);
	line_with(d.out, "\"name\"", line, sizeof(line));
	assert_has(line, "\"motor_id\":3,", "v4 round trip");
	assert_has(line, "\"name\":\"write_pid_rom\"", "v4 round trip");
	assert_has(line, "\"index\":5,\"gain\":0.25}", "v4 round trip");
	run_free(&e);
	run_free(&d);
}

/* ---- help and dispatch ---------------------------------------------------------------- */

static const struct run_case help_cases[] = {
	{ .args = { "--help" }, .out_has = { "usage: rmdctl", "decode", "encode", "exit status" } },
	{ .args = { "help" }, .out_has = { "usage: rmdctl" } },
	{ .args = { "help", "encode" }, .out_has = { "usage: rmdctl encode" } },
	{ .args = { "decode", "--help" }, .out_has = { "usage: rmdctl decode" } },
	{ .args = { "encode", "--help" }, .out_has = { "multi-torque" } },
};

static void test_help(void **state)
{
	(void)state;
	run_cases(rmdctl, help_cases, sizeof(help_cases) / sizeof(help_cases[0]), NULL);
}

static const struct run_case usage_cases[] = {
	/* an unknown subcommand */
	{ .args = { "frobnicate" }, .status = 2, .out_has = { "" }, .err_has = { "usage: rmdctl" } },
	{ .args = { "decode", "--bogus" }, .status = 2, .err_has = { "usage: rmdctl decode" } },
	{ .args = { "decode", "--protocol", "v9" }, .status = 2 },
	{ .args = { "decode", "--direction", "sideways" }, .status = 2 },
	{ .args = { "decode", "--protocol" }, .status = 2 },
	{ .args = { "decode", "/nonexistent/candump.log" },
	  .status = 1,
	  .err_has = { "/nonexistent/candump.log" } },
	{ .args = { NULL }, .status = 2, .err_has = { "usage: rmdctl" } }, /* argc == 1 */
};

static void test_usage_errors(void **state)
{
	(void)state;
	run_cases(rmdctl, usage_cases, sizeof(usage_cases) / sizeof(usage_cases[0]), NULL);
}

/* ---- issue 12: version, usage errors, --yes, --trace, move progress, completion ----------- */

/* `rmdctl --version`: "rmdctl VERSION", the version the build gave every program. */
static void test_version(void **state)
{
	char ver[128], want[160];
	struct run r;

	(void)state;
	snprintf(want, sizeof(want), "rmdctl %s\n", built_version(ver, sizeof(ver)));
	RUN(&r, NULL, "--version");
	assert_status(&r, 0, "--version");
	assert_string_equal(r.out, want);
	assert_string_equal(r.err, "");
	run_free(&r);
}

/* A usage error is one line (with a suggestion), the usage line and "see --help": no page. */
static const struct {
	const char *args[8];
	const char *first; /* the first line of stderr */
	const char *usage; /* the usage line */
} short_usage[] = {
	{ { "stauts" },
	  "rmdctl: unknown command \"stauts\" (did you mean status?)",
	  "usage: rmdctl COMMAND" },
	{ { "help", "mvoe" },
	  "rmdctl: no help for \"mvoe\" (did you mean move?)",
	  "usage: rmdctl COMMAND" },
	{ { "status", "1", "--bus", "sim", "--jsn" },
	  "rmdctl status: unknown option \"--jsn\" (did you mean --json?)",
	  "usage: rmdctl status [OPTIONS] ID" },
	{ { "move", "1", "--bus", "sim", "--yes", "--sped", "10" },
	  "rmdctl move: unknown option \"--sped\" (did you mean --speed?)",
	  "usage: rmdctl move [OPTIONS] ID DEG" },
	{ { "decode", "--protocl", "v3" },
	  "rmdctl decode: unknown option \"--protocl\" (did you mean --protocol?)",
	  "usage: rmdctl decode [OPTIONS] [FILE]" },
	{ { "encode", "--id", "1", "torq", "1" },
	  "rmdctl encode: unknown command \"torq\" (did you mean torque?)",
	  "usage: rmdctl encode [OPTIONS] COMMAND [ARGS...]" },
	{ { "top", "--jsn" },
	  "rmdctl top: unknown option \"--jsn\" (did you mean --json?)",
	  "usage: rmdctl top [OPTIONS]" },
	{ { "top", "--interval" },
	  "rmdctl top: --interval needs a value",
	  "usage: rmdctl top [OPTIONS]" },
	{ { "scan", "--frobnicate" },
	  "rmdctl scan: unknown option \"--frobnicate\"",
	  "usage: rmdctl scan [OPTIONS] [IDS]" },
	{ { NULL }, "rmdctl: missing COMMAND", "usage: rmdctl COMMAND" },
};

static void test_usage_error_is_short(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(short_usage) / sizeof(short_usage[0]); i++) {
		const char *first = short_usage[i].first;
		struct run r;

		run_argv(&r, NULL, short_usage[i].args);
		assert_status(&r, 2, first);
		assert_string_equal(r.out, "");
		if (strncmp(r.err, first, strlen(first)) || r.err[strlen(first)] != '\n')
			fail_msg("first line is not \"%s\":\n%s", first, r.err);
		assert_has(r.err, short_usage[i].usage, first);
		assert_has(r.err, "see `rmdctl", first);
		assert_has(r.err, "--help`\n", first);
		if (count_lines(r.err) != 3)
			fail_msg("%zu lines, expected 3:\n%s", count_lines(r.err), r.err);
		run_free(&r);
	}
}

/* --yes is accepted by every command, whether it asks anything or not. */
static void test_yes_everywhere(void **state)
{
	static const char *const cmds[][8] = {
		{ "scan", "1-3", "--bus", "sim:1-3", "--yes" },
		{ "info", "1", "--bus", "sim:1-3", "--yes" },
		{ "status", "1", "--bus", "sim:1-3", "-y" },
		{ "monitor", "1", "--once", "--bus", "sim:1-3", "--yes" },
		{ "stop", "1", "--bus", "sim:1-3", "--yes" },
		{ "off", "1", "--bus", "sim:1-3", "--yes" },
		{ "reset", "1", "--bus", "sim:1-3", "--yes" },
		{ "brake", "1", "on", "--bus", "sim:1-3", "--yes" },
		{ "accel", "1", "--bus", "sim:1-3", "--yes" },
		{ "pid", "1", "--bus", "sim:1-3", "--yes" },
		{ "set-zero", "1", "--bus", "sim:1-3", "--yes" },
		{ "set-timeout", "1", "100", "--bus", "sim:1-3", "--yes" },
		{ "move", "1", "1", "--bus", "sim:1-3", "--yes" },
		{ "encode", "--yes", "--id", "1", "stop" },
		{ "decode", "--yes" },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(cmds) / sizeof(cmds[0]); i++) {
		struct run r;

		run_argv(&r, "", cmds[i]);
		assert_status(&r, 0, cmds[i][0]);
		run_free(&r);
	}
}

/* ---- rtt ------------------------------------------------------------------------------- */

/* Simulated motors answering in 20 ms (turnaround_us): rtt must see 20 ms, no less. */
#define RTT_SIM_TURNAROUND_MS 20.0
/* What the run may add on a busy machine before it is run again (rmdctl's sleeps, the scheduler). */
#define RTT_SLACK_MS 3.0
#define RTT_RUNS 3

/*
 * One rtt run on sim:1-3 with a 20 ms turnaround: each motor's lines and
 * the summary.  Returns true when the run was judged, false when the
 * machine was too busy to tell (a median beyond the slack): run again.
 */
static bool rtt_sim_once(bool last)
{
	struct run r;
	char line[1024], sum[1024], cmd[16];
	double min_p99 = 1e9, max_p99 = 0, worst_median = 0;
	unsigned n;

	RUN(&r, "", "rtt", "1-3", "--bus", "sim:1-3", "--count", "10", "--sim",
	    "turnaround_us=20000", "--sim", "turnaround_jitter_us=0", "--json");
	assert_status(&r, 0, "rtt --json");
	for (n = 0; json_line(r.out, n, line, sizeof(line)); n++)
		;
	/* 3 motors x 3 commands, then the bus's summary */
	if (n != 10)
		fail_msg("%u JSON lines, expected 10:\n%s", n, r.out);
	for (unsigned i = 0; i < 9; i++) {
		double lo, med, p99;

		json_line(r.out, i, line, sizeof(line));
		json_str(line, "cmd", cmd, sizeof(cmd));
		if (json_num(line, "answered") != 10 || json_num(line, "lost") != 0)
			fail_msg("not every first try answered: %s", line);
		lo = json_num(line, "min_ms");
		med = json_num(line, "median_ms");
		p99 = json_num(line, "p99_ms");
		/* the sim's clock is the real one: no answer before its turnaround */
		if (lo < RTT_SIM_TURNAROUND_MS || med < lo || p99 < med ||
		    json_num(line, "max_ms") < p99)
			fail_msg("round trips below the 20 ms turnaround or out of order: %s",
				 line);
		worst_median = fmax(worst_median, med);
		min_p99 = fmin(min_p99, p99);
		max_p99 = fmax(max_p99, p99);
	}
	json_line(r.out, 9, sum, sizeof(sum));
	if (worst_median > RTT_SIM_TURNAROUND_MS + RTT_SLACK_MS && !last) {
		fprintf(stderr, "busy machine: median round trip %.3f ms, running rtt again\n",
			worst_median);
		run_free(&r);
		return false;
	}
	if (worst_median > RTT_SIM_TURNAROUND_MS + RTT_SLACK_MS)
		fail_msg("median round trip %.3f ms in %d runs, expected about %.0f ms",
			 worst_median, RTT_RUNS, RTT_SIM_TURNAROUND_MS);
	/* CAN carries the 3 requests at once: the slowest p99 is the cycle, under 50 Hz */
	if (json_num(sum, "rate_hz") >= 50 || json_num(sum, "rate_hz") < 1 ||
	    json_num(sum, "motors") != 3 || json_bool(sum, "half_duplex"))
		fail_msg("summary: %s", sum);
	if (fabs(json_num(sum, "rate_hz") - floor(1000.0 / max_p99)) > 1)
		fail_msg("rate %g Hz does not follow from the slowest p99 %.3f ms: %s",
			 json_num(sum, "rate_hz"), max_p99, sum);
	(void)min_p99;
	run_free(&r);

	/* the text form says the same in words */
	RUN(&r, "", "rtt", "1", "--bus", "sim:1", "--count", "3", "--sim", "turnaround_us=20000");
	assert_status(&r, 0, "rtt");
	if (!strstr(r.out, "supported loop rate") || !strstr(r.out, "0x92") ||
	    !strstr(r.out, "P99_MS"))
		fail_msg("rtt text:\n%s", r.out);
	run_free(&r);
	return true;
}

static void test_rtt_sim(void **state)
{
	(void)state;
	for (int k = 0; k < RTT_RUNS && !rtt_sim_once(k == RTT_RUNS - 1); k++)
		;
}

/*
 * V4 motors left pushing 0x9C every 20 ms by another tool (V4.2 §2.33):
 * they do not answer 0x9C, and a push must not pass for an answer.  rtt
 * says so and measures the other commands; the rate follows from those.
 */
static void test_rtt_pushed(void **state)
{
	struct run r;
	char line[1024], cmd[16];
	double max_p99 = 0;
	unsigned n;

	(void)state;
	RUN(&r, "", "rtt", "1-2", "--bus", "sim:1-2", "--protocol", "v4", "--count", "5", "--sim",
	    "active_reply_9c_ms=20", "--json");
	assert_status(&r, 0, "rtt --json, motors pushing 0x9C");
	for (n = 0; json_line(r.out, n, line, sizeof(line)); n++)
		;
	if (n != 7)
		fail_msg("%u JSON lines, expected 7:\n%s", n, r.out);
	for (unsigned i = 0; i < 6; i++) {
		bool pushed;

		json_line(r.out, i, line, sizeof(line));
		json_str(line, "cmd", cmd, sizeof(cmd));
		pushed = json_bool(line, "pushed");
		if (pushed != !strcmp(cmd, "0x9C"))
			fail_msg("pushed says %d: %s", pushed, line);
		if (json_num(line, "answered") != (pushed ? 0 : 5) || json_num(line, "lost") != 0)
			fail_msg("answered or lost: %s", line);
		if (!pushed && json_num(line, "p99_ms") > max_p99)
			max_p99 = json_num(line, "p99_ms");
	}
	/*
	 * the bus's rate (the last "rate_hz", after the classes') follows from
	 * what was measured (CAN: the slowest p99), not from the pushes
	 */
	json_line(r.out, 6, line, sizeof(line));
	{
		const char *p = line, *last = NULL;
		double rate = 0;

		while ((p = strstr(p, "\"rate_hz\":")))
			last = p++;
		if (!last || sscanf(last, "\"rate_hz\":%lf", &rate) != 1 || max_p99 <= 0 ||
		    fabs(rate - floor(1000.0 / max_p99)) > 1 || strstr(line, "0x9C"))
			fail_msg("rate against the slowest measured p99 %.3f ms: %s", max_p99,
				 line);
	}
	for (unsigned id = 1; id <= 2; id++) {
		char want[64];

		snprintf(want, sizeof(want), "motor %u pushes 0x9C unasked", id);
		if (!strstr(r.err, want))
			fail_msg("no \"%s\" on stderr:\n%s", want, r.err);
	}
	run_free(&r);
}

/* --sim takes the parameter table's keys only, with their ranges. */
static void test_rtt_usage(void **state)
{
	static const char *const bad[][8] = {
		{ "rtt", "--bus", "sim:1", "--sim", "no_such_key=1" },
		{ "rtt", "--bus", "sim:1", "--sim", "turnaround_us" },
		{ "rtt", "--bus", "sim:1", "--sim", "turnaround_us=-5" },
		{ "rtt", "--bus", "sim:1", "--count", "0" },
		{ "status", "1", "--count", "5", "--bus", "sim:1" },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		struct run r;

		run_argv(&r, "", bad[i]);
		assert_status(&r, 2, bad[i][3]);
		run_free(&r);
	}
}

/* A candump -l line: "(SSSSSSSSSS.UUUUUU) IFACE ID#DATA", nothing else. */
static bool is_candump_l(const char *s, size_t len)
{
	size_t i = 0, k;

	if (len < 21 || s[0] != '(' || s[11] != '.' || s[18] != ')' || s[19] != ' ')
		return false;
	for (k = 1; k < 18; k++)
		if (k != 11 && (s[k] < '0' || s[k] > '9'))
			return false;
	for (i = 20; i < len && s[i] != ' '; i++)
		if (s[i] == '#')
			return false;
	if (i == 20 || i - 20 > 15 || i + 5 > len)
		return false;
	for (k = i + 1; k < i + 4; k++)
		if (!strchr("0123456789ABCDEF", s[k]))
			return false;
	if (s[i + 4] != '#' || (len - i - 5) % 2 || len - i - 5 > 16)
		return false;
	for (k = i + 5; k < len; k++)
		if (!strchr("0123456789ABCDEF", s[k]))
			return false;
	return true;
}

/*
 * --trace: every frame is an exact candump -l line, followed by a '#'
 * comment (canplayer reads only lines that start with '('); rmdctl decode
 * reads the whole trace back, frame for frame.
 */
static void test_trace_is_candump_l(void **state)
{
	unsigned frames = 0, comments = 0, decoded = 0;
	struct run r, d;
	const char *p;

	(void)state;
	RUN(&r, NULL, "status", "1", "--bus", "sim:1-3", "--trace");
	assert_status(&r, 0, "status --trace");
	for (p = r.err; *p;) {
		size_t len = strcspn(p, "\n");

		if (p[0] == '(') {
			if (!is_candump_l(p, len))
				fail_msg("not a candump -l line: \"%.*s\"", (int)len, p);
			if (strncmp(p + len, "\n# ", 3))
				fail_msg("no comment after \"%.*s\"", (int)len, p);
			frames++;
		} else if (!strncmp(p, "# TX ", 5) || !strncmp(p, "# RX ", 5)) {
			comments++;
		} else {
			fail_msg("a trace line that is neither: \"%.*s\"", (int)len, p);
		}
		p += len + (p[len] == '\n');
	}
	/* 0x9A, 0x92, 0x9C out and back at least */
	assert_true(frames >= 6);
	assert_int_equal(frames, comments);
	assert_has(r.err, " sim:1-3 141#9A00000000000000\n# TX read_status_1", "trace");

	run_argv(&d, r.err, (const char *const[]){ "decode", "--json", NULL });
	assert_status(&d, 0, "decode of the trace");
	for (p = d.out; (p = strstr(p, "\"interface\":\"sim:1-3\"")); p++)
		decoded++;
	assert_int_equal(decoded, frames);
	assert_has(d.out, "\"raw\":\"9A00000000000000\"", "decode of the trace");
	assert_has(d.out, "\"name\":\"read_status_1\"", "decode of the trace");
	run_free(&d);
	run_free(&r);
}

/* Read a pty master until the child exits; its output into buf.  The exit status. */
static int pty_finish(pid_t pid, int m, char *buf, size_t size)
{
	size_t len = 0;
	int ws = 0;
	bool done = false;

	for (int waited_ms = 0; waited_ms < 30000;) {
		struct pollfd pfd = { .fd = m, .events = POLLIN };
		ssize_t k;

		if (poll(&pfd, 1, 10) <= 0) {
			waited_ms += 10;
			if (done)
				break;
			done = waitpid(pid, &ws, WNOHANG) == pid;
			continue;
		}
		k = read(m, buf + len, size - 1 - len);
		if (k <= 0) {
			if (!done)
				done = waitpid(pid, &ws, 0) == pid;
			break;
		}
		len += (size_t)k;
	}
	if (!done) {
		kill(pid, SIGKILL);
		waitpid(pid, &ws, 0);
		fail_msg("rmdctl on a terminal did not exit; output:\n%.*s", (int)len, buf);
	}
	close(m);
	buf[len] = '\0';
	return WIFEXITED(ws) ? WEXITSTATUS(ws) : 128 + WTERMSIG(ws);
}

/* move shows where the motor is on a terminal, and nothing of it on a pipe. */
static void test_move_progress_on_terminal(void **state)
{
	static const char *const args[] = { "move", "2", "10", "--bus", "sim", "--yes", NULL };
	static char out[65536];
	unsigned updates = 0;
	struct run r;
	const char *p;
	int m;
	pid_t pid;

	(void)state;
	pid = spawn_pty(rmdctl, args, &m, NULL, NULL);
	assert_int_equal(pty_finish(pid, m, out, sizeof(out)), 0);
	for (p = out; (p = strstr(p, "\rsim: motor 2: ")); p++) {
		const char *of = strstr(p, " deg of 10.00 ("), *next = strchr(p + 1, '\r');

		updates += of && (!next || of < next);
	}
	/* a 10 deg move at 30 dps takes about 0.33 s: a line every 20 ms poll */
	if (updates < 3)
		fail_msg("%u progress updates on the terminal:\n%s", updates, out);
	assert_has(out, "(100 %)", "progress");
	/* the line is erased before the result */
	assert_has(out, "\r\033[Ksim: motor 2: at 10.00 deg", "progress");

	run_argv(&r, NULL, args);
	assert_status(&r, 0, "move on a pipe");
	assert_lacks(r.out, "deg of", "move on a pipe");
	assert_lacks(r.out, "\r", "move on a pipe");
	assert_has(r.out, "sim: motor 2: at 10.00 deg", "move on a pipe");
	run_free(&r);
}

/*
 * The bash completion the build wrote is `rmdctl --completion bash`: the
 * commands, each command's own options, --bus from the CAN interfaces.
 */
/*
 * restore refuses a bad file before it touches a bus, naming the file, the
 * line and what is wrong (exit 1): a pid that is not a mapping, an unknown
 * key, missing gains, an unknown protocol, no motors list.
 */
static void test_restore_bad_files(void **state)
{
	static const struct {
		const char *yaml, *want;
	} cases[] = {
		{ "protocol: v3\nmotors:\n  - id: 1\n    pid: 3\n",
		  ".yaml:4: pid: want a mapping of the gains\n" },
		{ "protocol: v3\nmotors:\n  - id: 1\n    speed: 3\n",
		  ".yaml:4: unknown key (id, pid, accel_dps2, zero_offset, comm_loss_ms;" },
		{ "protocol: v3\nmotors:\n  - id: 1\n    pid: {current_kp: 1}\n",
		  ".yaml:4: pid: give all the gains of protocol v3 (current_kp, current_ki," },
		{ "protocol: v9\nmotors: []\n", ".yaml:1: protocol: not a protocol key" },
		{ "protocol: v3\n", ".yaml: no `motors:` list (write one with rmdctl dump)\n" },
		{ "motors:\n  - {accel_dps2: 1000}\n", ".yaml:2: a motor without id\n" },
	};
	char path[64];

	(void)state;
	snprintf(path, sizeof(path), "/tmp/rmdctl-restore-%d.yaml", (int)getpid());
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		FILE *f = fopen(path, "w");
		struct run r;

		assert_non_null(f);
		fputs(cases[i].yaml, f);
		assert_int_equal(fclose(f), 0);
		RUN(&r, NULL, "restore", "--bus", "sim", "--yes", path);
		if (r.status != 1 || !strstr(r.err, cases[i].want) || !strstr(r.err, path))
			fail_msg("case %zu: exit %d, stderr:\n%s\nwant \"%s\" after the path", i,
				 r.status, r.err, cases[i].want);
		run_free(&r);
	}
	unlink(path);
}

static void test_completion(void **state)
{
	char net[64], path[600];
	struct run r, gen;

	(void)state;
	RUN(&gen, NULL, "--completion", "bash");
	assert_status(&gen, 0, "--completion bash");
	snprintf(path, sizeof(path), "%s/completion/rmdctl",
		 getenv("BUILD") && *getenv("BUILD") ? getenv("BUILD") : "build");
	run_prog(&r, "/usr/bin/cmp", (const char *const[]){ path, "-", NULL },
		 &(struct run_opts){ .input = gen.out, .input_len = strlen(gen.out) });
	assert_status(&r, 0, "the installed script is rmdctl --completion bash");
	run_free(&r);
	run_free(&gen);

	assert_completion("rmdctl", "rmdctl sta", NULL, "status\n");
	run_completion(&r, "rmdctl", "rmdctl s", NULL);
	ASSERT_HAS_ALL(r.out, "rmdctl s", "scan\n", "status\n", "set-id\n", "stop\n");
	run_free(&r);
	assert_completion("rmdctl", "rmdctl help mo", NULL, "monitor\nmove\n");
	/* each command's own options: move has --speed, status has not */
	assert_completion("rmdctl", "rmdctl move 1 10 --sp", NULL, "--speed\n");
	assert_completion("rmdctl", "rmdctl status 1 --sp", NULL, "\n");
	assert_completion("rmdctl", "rmdctl decode --protocol ", NULL, "v3\nv2\nmit\nv4\n");
	assert_completion("rmdctl", "rmdctl status 1 --protocol ", NULL, "v3\nv2\nv4\n");
	/* top's options come from its table too */
	assert_completion("rmdctl", "rmdctl top --lcm", NULL, "--lcm-url\n");
	assert_completion("rmdctl", "rmdctl top --in", NULL, "--interval\n");

	fake_net_dir(net, sizeof(net));
	run_completion(&r, "rmdctl", "rmdctl scan --bus ", net);
	ASSERT_HAS_ALL(r.out, "--bus", "can0\n", "vcan1\n", "sim\n");
	assert_lacks(r.out, "eth0", "--bus");
	run_free(&r);
	assert_completion("rmdctl", "rmdctl status 1 -b vc", net, "vcan1\n");
	assert_int_equal(rm_tree(net), 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_decode_json_sample),
		cmocka_unit_test(test_decode_errors),
		cmocka_unit_test(test_decode_text),
		cmocka_unit_test(test_decode_stdin),
		cmocka_unit_test(test_decode_long_line),
		cmocka_unit_test(test_decode_nul_and_binary),
		cmocka_unit_test(test_decode_mit_ranges),
		cmocka_unit_test(test_decode_v2_and_direction),
		cmocka_unit_test(test_decode_v4),
		cmocka_unit_test(test_decode_json_valid),
		cmocka_unit_test(test_encode),
		cmocka_unit_test(test_encode_messages),
		cmocka_unit_test(test_encode_decode_round_trip),
		cmocka_unit_test(test_help),
		cmocka_unit_test(test_usage_errors),
		cmocka_unit_test(test_version),
		cmocka_unit_test(test_usage_error_is_short),
		cmocka_unit_test(test_yes_everywhere),
		cmocka_unit_test(test_rtt_sim),
		cmocka_unit_test(test_rtt_pushed),
		cmocka_unit_test(test_rtt_usage),
		cmocka_unit_test(test_trace_is_candump_l),
		cmocka_unit_test(test_move_progress_on_terminal),
		cmocka_unit_test(test_restore_bad_files),
		cmocka_unit_test(test_completion),
	};

	return cmocka_run_group_tests_name("rmdctl", tests, setup, NULL);
}
