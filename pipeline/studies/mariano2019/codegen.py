"""C code for the ATmega328P: the FK of a DH chain by HTM or by unit DQ, plus a measuring harness.

The generated program follows the function split of the document's sketch (Table V of
003_8b306f4736fa5051.txt): one transformation function called per link (4 calls), one product
function called per pair (3 calls), one translation function; matrices / DQs are global ``float``
arrays (the 7 intermediate poses), as an Arduino sketch keeps them. The functions are the general
ones of eqs. 21-22 (all four DH parameters at run time, full products), so the C executes exactly
the operations counted by :func:`~pipeline.studies.mariano2019.algebra.general_chain_counts`
(the DQ link's halvings are multiplications by 0.5f).

The harness (not timed) sets Timer1 to count CPU cycles (prescaler 1, overflow interrupt for the
high word), paints the free stack to find its peak use, runs the FK on each joint configuration,
and writes one line per configuration on USART0 (read by simavr): the result as IEEE-754 hex words
and the cycles of the three stages. ``variant = "baseline"`` is the harness with no kinematics
(its flash/SRAM are subtracted to give the FK's own share).

The print variants (:func:`generate_print_program`, ``PRINT_VARIANTS``) run the same FK code and
then, still inside the timed region, print the result the way an Arduino sketch's ``print_array``
would: the final 4x4 matrix (HTM, 16 floats, one row per line) or the final dual quaternion (DQ, 8
floats), each float as Arduino's ``Print::print(float)`` writes it (2 decimals), a space after each
value and ``"\r\n"`` after each line. The UART is set as Arduino's ``HardwareSerial::begin`` does
(U2X, UBRR = (F_CPU/4/baud - 1)/2) and each character waits for UDRE0 (a blocking write). Baud
``PRINT_BUFFERED`` (0) writes the text to a RAM buffer instead (the formatting alone, no UART wait)
and sends it after the timed region. The FK-only programs are not changed by any of this.
"""

from __future__ import annotations

VARIANTS = ("baseline", "htm", "dq")
PRINT_VARIANTS = ("htm_print", "dq_print")
PRINT_BUFFERED = 0            # "baud" of the print variant that formats into RAM (no UART inside the timed region)
PRINT_BAUDS = (PRINT_BUFFERED, 9600, 115200)  # 9600: Serial.begin's usual rate in Arduino sketches of the time
PRINT_DIGITS = 2              # Arduino Print::print(float) default
PRINT_VALUES = {"htm_print": 16, "dq_print": 8}
PRINT_BUFFER_BYTES = 256
OPS = ("load_store", "add", "mul", "div", "sqrt", "sin", "cos", "atan2")

HARNESS_TOP = r"""
#include <avr/io.h>
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include <math.h>
#include <stdint.h>

static void uart_init(void) { UBRR0H = 0; UBRR0L = 0; UCSR0A = (1 << U2X0); UCSR0B = (1 << TXEN0); UCSR0C = (3 << UCSZ00); }
static void putch(char c) { while (!(UCSR0A & (1 << UDRE0))) {} UDR0 = c; }
static void puts_(const char *s) { while (*s) putch(*s++); }
static void puthex32(uint32_t v) { for (int8_t i = 28; i >= 0; i -= 4) putch("0123456789abcdef"[(v >> i) & 15]); }
static void putu32(uint32_t v) { char b[11]; int8_t n = 0; do { b[n++] = '0' + v % 10; v /= 10; } while (v); while (n) putch(b[--n]); }
static void putf(const char *k, float f) { union { float f; uint32_t u; } x; x.f = f; puts_(k); puthex32(x.u); putch(' '); }
static void putc32(const char *k, uint32_t v) { puts_(k); putu32(v); putch(' '); }

static volatile uint16_t ovf;
ISR(TIMER1_OVF_vect) { ovf++; }
static inline uint32_t now(void) {
  uint8_t s = SREG; cli();
  uint16_t t = TCNT1; uint16_t o = ovf;
  if ((TIFR1 & (1 << TOV1)) && t < 0x8000) o++;
  SREG = s;
  return ((uint32_t)o << 16) | t;
}
static void timer_start(void) { TCCR1A = 0; TCCR1B = 0; TCNT1 = 0; ovf = 0; TIFR1 = (1 << TOV1); TIMSK1 = (1 << TOIE1); sei(); TCCR1B = (1 << CS10); }

extern uint8_t __heap_start;
#define PAINT 0xC5
static void paint_stack(void) {
  uint8_t *p = &__heap_start; uint8_t *sp = (uint8_t *)SP;
  while (p < sp - 8) *p++ = PAINT;
}
static uint16_t stack_peak(void) {
  uint8_t *p = &__heap_start;
  while (*p == PAINT && p < (uint8_t *)RAMEND) p++;
  return (uint16_t)((uint8_t *)RAMEND - p + 1);
}
"""

HTM_CODE = r"""
float T1[4][4], T2[4][4], T3[4][4], T4[4][4], T12[4][4], T123[4][4], T1234[4][4];
float P[3];

__attribute__((noinline)) void htm_dh(float T[4][4], float a, float alpha, float d, float theta) {
  float ct = cos(theta), st = sin(theta), ca = cos(alpha), sa = sin(alpha);
  T[0][0] = ct; T[0][1] = -st * ca; T[0][2] = st * sa;  T[0][3] = a * ct;
  T[1][0] = st; T[1][1] = ct * ca;  T[1][2] = -ct * sa; T[1][3] = a * st;
  T[2][0] = 0;  T[2][1] = sa;       T[2][2] = ca;       T[2][3] = d;
  T[3][0] = 0;  T[3][1] = 0;        T[3][2] = 0;        T[3][3] = 1;
}

__attribute__((noinline)) void mat_mul(float C[4][4], float A[4][4], float B[4][4]) {
  for (uint8_t i = 0; i < 4; i++)
    for (uint8_t j = 0; j < 4; j++) {
      float s = A[i][0] * B[0][j];
      for (uint8_t k = 1; k < 4; k++) s += A[i][k] * B[k][j];
      C[i][j] = s;
    }
}

__attribute__((noinline)) void translation(float T[4][4], float p[3]) { p[0] = T[0][3]; p[1] = T[1][3]; p[2] = T[2][3]; }

#define LINKS(q) do { htm_dh(T1, DH_A[0], DH_ALPHA[0], DH_D[0], q[0]); htm_dh(T2, DH_A[1], DH_ALPHA[1], DH_D[1], q[1]); \
  htm_dh(T3, DH_A[2], DH_ALPHA[2], DH_D[2], q[2]); htm_dh(T4, DH_A[3], DH_ALPHA[3], DH_D[3], q[3]); } while (0)
#define PRODUCTS() do { mat_mul(T12, T1, T2); mat_mul(T123, T12, T3); mat_mul(T1234, T123, T4); } while (0)
#define TRANSLATION() translation(T1234, P)
"""

DQ_CODE = r"""
float Q1[8], Q2[8], Q3[8], Q4[8], Q12[8], Q123[8], Q1234[8];
float P[3];

__attribute__((noinline)) void dq_dh(float Q[8], float a, float alpha, float d, float theta) {
  float ht = 0.5f * theta, ha = 0.5f * alpha;
  float ct = cos(ht), st = sin(ht), ca = cos(ha), sa = sin(ha);
  float a2 = 0.5f * a, d2 = 0.5f * d;
  float cc = ca * ct, sc = sa * ct, ss = sa * st, cs = ca * st;
  Q[0] = cc; Q[1] = sc; Q[2] = ss; Q[3] = cs;
  Q[4] = -a2 * sc - d2 * cs; Q[5] = a2 * cc - d2 * ss; Q[6] = a2 * cs + d2 * sc; Q[7] = -a2 * ss + d2 * cc;
}

static inline void q_mul(float r[4], const float p[4], const float q[4]) {
  r[0] = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3];
  r[1] = p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2];
  r[2] = p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1];
  r[3] = p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0];
}

__attribute__((noinline)) void dq_mul(float C[8], float A[8], float B[8]) {
  float d1[4], d2[4];
  q_mul(C, A, B);
  q_mul(d1, A, B + 4);
  q_mul(d2, A + 4, B);
  for (uint8_t i = 0; i < 4; i++) C[4 + i] = d1[i] + d2[i];
}

__attribute__((noinline)) void translation(float Q[8], float p[3]) {
  p[0] = 2.0f * (-Q[1] * Q[4] + Q[0] * Q[5] - Q[3] * Q[6] + Q[2] * Q[7]);
  p[1] = 2.0f * (-Q[2] * Q[4] + Q[3] * Q[5] + Q[0] * Q[6] - Q[1] * Q[7]);
  p[2] = 2.0f * (-Q[3] * Q[4] - Q[2] * Q[5] + Q[1] * Q[6] + Q[0] * Q[7]);
}

#define LINKS(q) do { dq_dh(Q1, DH_A[0], DH_ALPHA[0], DH_D[0], q[0]); dq_dh(Q2, DH_A[1], DH_ALPHA[1], DH_D[1], q[1]); \
  dq_dh(Q3, DH_A[2], DH_ALPHA[2], DH_D[2], q[2]); dq_dh(Q4, DH_A[3], DH_ALPHA[3], DH_D[3], q[3]); } while (0)
#define PRODUCTS() do { dq_mul(Q12, Q1, Q2); dq_mul(Q123, Q12, Q3); dq_mul(Q1234, Q123, Q4); } while (0)
#define TRANSLATION() translation(Q1234, P)
"""

BASELINE_CODE = r"""
float P[3];
#define LINKS(q) do { P[0] = q[0]; P[1] = q[1]; P[2] = q[2] + q[3]; } while (0)
#define PRODUCTS() do { } while (0)
#define TRANSLATION() do { } while (0)
"""

MAIN = r"""
int main(void) {
  uart_init();
  paint_stack();
  timer_start();
  uint32_t t0 = now(), t1 = now();
  uint32_t overhead = t1 - t0;
  putc32("OVERHEAD ", overhead); puts_("\n");
  for (uint8_t c = 0; c < NCONF; c++) {
    volatile float *qv = QCONF[c];
    float q[4] = {qv[0], qv[1], qv[2], qv[3]};
    uint32_t a = now();
    LINKS(q);
    uint32_t b = now();
    PRODUCTS();
    uint32_t e = now();
    TRANSLATION();
    uint32_t f = now();
    puts_("CONF "); putc32("i=", c);
    putf("x=", P[0]); putf("y=", P[1]); putf("z=", P[2]);
    putc32("links=", b - a - overhead); putc32("products=", e - b - overhead);
    putc32("translation=", f - e - overhead); putc32("total=", f - a - 3 * overhead);
    puts_("\n");
  }
  putc32("STACK ", stack_peak()); puts_("\nEND\n");
  while (!(UCSR0A & (1 << TXC0))) {}
  cli();
  sleep_cpu();
  return 0;
}
"""


def _farr(vals) -> str:
    return "{" + ", ".join(f"{float(v)!r}f" for v in vals) + "}"


def _check(chain, q_configs):
    import numpy as np

    if chain.n != 4 or chain.convention != "standard" or chain.prismatic.any() or np.any(chain.theta_offset):
        raise ValueError("the MCU program is generated for a 4-link standard-DH revolute chain without offsets")
    q = np.asarray(q_configs, dtype=float)
    if q.ndim != 2 or q.shape[1] != 4 or q.shape[0] < 1:
        raise ValueError(f"q_configs must have shape (k, 4), got {q.shape}")
    return q


def generate_fk_program(variant: str, chain, q_configs) -> str:
    """C source of one firmware.

    Parameters
    ----------
    variant : {"baseline", "htm", "dq"}
    chain : pipeline.kinematics.Chain
        Standard-DH, revolute, 4 links (the document's arm; the DH constants are emitted as
        ``volatile`` globals so the compiler cannot fold them, as in a sketch that keeps them in
        variables).
    q_configs : array_like, shape (k, 4) [rad]

    Returns
    -------
    str
    """
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r} (have {VARIANTS})")
    q = _check(chain, q_configs)
    consts = _consts(chain, q)
    body = {"baseline": BASELINE_CODE, "htm": HTM_CODE, "dq": DQ_CODE}[variant]
    return "\n".join([f"/* generated by pipeline.studies.mariano2019.codegen: variant {variant} */",
                      HARNESS_TOP, *consts, body, MAIN])


PRINT_TOP = r"""
static uint16_t nchar;
#if PRINT_TO_RAM
static char pbuf[PBUF];
static void pputc(char c) { if (nchar < PBUF) pbuf[nchar] = c; nchar++; }
#else
static void pputc(char c) { putch(c); nchar++; }
#endif
/* Arduino Print::printNumber(n, 10) */
static void print_ulong(unsigned long n) {
  char buf[8 * sizeof(long) + 1]; char *str = &buf[sizeof(buf) - 1];
  *str = '\0';
  do { char c = n % 10; n /= 10; *--str = c + '0'; } while (n);
  while (*str) pputc(*str++);
}
/* Arduino Print::printFloat(number, digits) */
__attribute__((noinline)) void print_float(double number, uint8_t digits) {
  if (isnan(number)) { pputc('n'); pputc('a'); pputc('n'); return; }
  if (isinf(number)) { pputc('i'); pputc('n'); pputc('f'); return; }
  if (number > 4294967040.0 || number < -4294967040.0) { pputc('o'); pputc('v'); pputc('f'); return; }
  if (number < 0.0) { pputc('-'); number = -number; }
  double rounding = 0.5;
  for (uint8_t i = 0; i < digits; ++i) rounding /= 10.0;
  number += rounding;
  unsigned long int_part = (unsigned long)number;
  double remainder = number - (double)int_part;
  print_ulong(int_part);
  if (digits > 0) pputc('.');
  while (digits-- > 0) { remainder *= 10.0; unsigned int toPrint = (unsigned int)remainder; print_ulong(toPrint); remainder -= toPrint; }
}
static void print_ln(void) { pputc('\r'); pputc('\n'); }
/* Arduino HardwareSerial::begin: UCSR0A (U2X) first, then UBRR (simavr computes its byte time on the UBRR0L write) */
static void uart_init_print(void) {
  UCSR0A = PRINT_U2X ? (1 << U2X0) : 0; UBRR0H = PRINT_UBRR >> 8; UBRR0L = PRINT_UBRR & 0xff;
  UCSR0B = (1 << TXEN0); UCSR0C = (3 << UCSZ00);
}
"""

HTM_PRINT = r"""
__attribute__((noinline)) void print_array(float A[4][4]) {
  for (uint8_t i = 0; i < 4; i++) {
    for (uint8_t j = 0; j < 4; j++) { print_float(A[i][j], PRINT_DIGITS); pputc(' '); }
    print_ln();
  }
}
#define PRINT_RESULT() print_array(T1234)
"""

DQ_PRINT = r"""
__attribute__((noinline)) void print_array(float Q[8]) {
  for (uint8_t i = 0; i < 8; i++) { print_float(Q[i], PRINT_DIGITS); pputc(' '); }
  print_ln();
}
#define PRINT_RESULT() print_array(Q1234)
"""

PRINT_MAIN = r"""
int main(void) {
#if PRINT_TO_RAM
  uart_init();
#else
  uart_init_print();
#endif
  timer_start();
  uint32_t t0 = now(), t1 = now();
  uint32_t overhead = t1 - t0;
  putc32("OVERHEAD ", overhead); puts_("\n");
  for (uint8_t c = 0; c < NCONF; c++) {
    volatile float *qv = QCONF[c];
    float q[4] = {qv[0], qv[1], qv[2], qv[3]};
    puts_("PRINT\n");
    while (!(UCSR0A & (1 << UDRE0))) {}   /* simavr: UDRE0 rises when the last byte has left, the UART is idle */
    nchar = 0;
    uint32_t a = now();
    LINKS(q);
    PRODUCTS();
    TRANSLATION();
    uint32_t b = now();
    PRINT_RESULT();
    uint32_t e = now();
#if PRINT_TO_RAM
    for (uint16_t k = 0; k < nchar && k < PBUF; k++) putch(pbuf[k]);
#endif
    puts_("PCONF "); putc32("i=", c);
    putf("x=", P[0]); putf("y=", P[1]); putf("z=", P[2]);
    putc32("fk=", b - a - overhead); putc32("print=", e - b - overhead); putc32("total=", e - a - 2 * overhead);
    putc32("chars=", nchar);
    puts_("\n");
  }
  puts_("END\n");
  while (!(UCSR0A & (1 << TXC0))) {}
  cli();
  sleep_cpu();
  return 0;
}
"""


def uart_setting(baud: int, freq_hz: float) -> dict:
    """UART registers as Arduino's ``HardwareSerial::begin(baud)`` sets them (1.0.x; the 57600 exception
    at 16 MHz included) -> ``{"baud": nominal, "ubrr", "u2x", "baud_actual"}``; baud ``PRINT_BUFFERED``
    (no UART in the timed region) -> the harness's own fast setting, ``baud_actual`` 0."""
    if baud == PRINT_BUFFERED:
        return {"baud": PRINT_BUFFERED, "ubrr": 0, "u2x": True, "baud_actual": 0.0}
    if baud <= 0:
        raise ValueError(f"baud must be positive (or {PRINT_BUFFERED} for no UART), got {baud}")
    f = int(freq_hz)
    u2x = not (f == 16_000_000 and baud == 57600)
    ubrr = (f // 4 // baud - 1) // 2 if u2x else (f // 8 // baud - 1) // 2
    if ubrr > 4095 and u2x:
        u2x, ubrr = False, (f // 8 // baud - 1) // 2
    if not 0 <= ubrr <= 4095:
        raise ValueError(f"baud {baud} cannot be set at {f} Hz")
    return {"baud": int(baud), "ubrr": int(ubrr), "u2x": u2x, "baud_actual": f / ((8 if u2x else 16) * (ubrr + 1))}


def _consts(chain, q) -> list[str]:
    return [
        f"volatile float DH_A[4] = {_farr(chain.a)};",
        f"volatile float DH_ALPHA[4] = {_farr(chain.alpha)};",
        f"volatile float DH_D[4] = {_farr(chain.d)};",
        f"#define NCONF {q.shape[0]}",
        "volatile float QCONF[NCONF][4] = {" + ", ".join(_farr(r) for r in q) + "};",
    ]


def generate_print_program(variant: str, chain, q_configs, baud: int, freq_hz: float) -> str:
    """C source of one print-variant firmware: the FK of ``htm`` / ``dq`` followed, inside the same
    timed region, by printing its final pose (``print_array``: 16 or 8 floats, 2 decimals).

    Parameters
    ----------
    variant : {"htm_print", "dq_print"}
    chain : pipeline.kinematics.Chain
        As for :func:`generate_fk_program`.
    q_configs : array_like, shape (k, 4) [rad]
    baud : int
        Serial rate [bit/s] set as Arduino does (blocking write of each character), or
        ``PRINT_BUFFERED`` (0): the text goes to RAM in the timed region and is sent after it.
    freq_hz : float
        CPU clock [Hz] (for UBRR).

    Returns
    -------
    str
    """
    if variant not in PRINT_VARIANTS:
        raise ValueError(f"unknown print variant {variant!r} (have {PRINT_VARIANTS})")
    q = _check(chain, q_configs)
    u = uart_setting(baud, freq_hz)
    to_ram = baud == PRINT_BUFFERED
    defs = [f"#define PRINT_TO_RAM {int(to_ram)}", f"#define PBUF {PRINT_BUFFER_BYTES}",
            f"#define PRINT_DIGITS {PRINT_DIGITS}", f"#define PRINT_UBRR {u['ubrr']}", f"#define PRINT_U2X {int(u['u2x'])}"]
    body = {"htm_print": HTM_CODE + HTM_PRINT, "dq_print": DQ_CODE + DQ_PRINT}[variant]
    return "\n".join([f"/* generated by pipeline.studies.mariano2019.codegen: variant {variant}, "
                      f"{'text to RAM' if to_ram else f'{baud} baud'} */",
                      HARNESS_TOP, *defs, PRINT_TOP, *_consts(chain, q), body, PRINT_MAIN])


OPS_MAIN = r"""
volatile float OPA[NVAL] = OPA_INIT, OPB[NVAL] = OPB_INIT;
volatile float R;
#define MEASURE(name, expr) do { for (uint8_t i = 0; i < NVAL; i++) { float a = OPA[i], b = OPB[i]; (void)b; \
  uint32_t t0 = now(); R = (expr); uint32_t t1 = now(); \
  puts_("OP "); puts_(name); putc32(" i=", i); putc32("cycles=", t1 - t0 - overhead); puts_("\n"); } } while (0)
int main(void) {
  uart_init();
  timer_start();
  uint32_t t0 = now(), t1 = now();
  uint32_t overhead = t1 - t0;
  MEASURE("load_store", a);
  MEASURE("add", a + b);
  MEASURE("mul", a * b);
  MEASURE("div", a / b);
  MEASURE("sqrt", sqrt(a));
  MEASURE("sin", sin(a));
  MEASURE("cos", cos(a));
  MEASURE("atan2", atan2(a, b));
  puts_("END\n");
  while (!(UCSR0A & (1 << TXC0))) {}
  cli();
  sleep_cpu();
  return 0;
}
"""


def generate_ops_program(a_values, b_values) -> str:
    """C source measuring the cycles of one float operation (+, x, /, sqrt, sin, cos, atan2) per
    operand pair (Gráfico 4 of 003, measured instead of assumed). ``load_store`` is the same
    statement with no operation (the cost of moving the operands), reported for subtraction."""
    if len(a_values) != len(b_values) or not len(a_values):
        raise ValueError("a_values and b_values must be non-empty and of equal length")
    return "\n".join(["/* generated by pipeline.studies.mariano2019.codegen: operation costs */",
                      HARNESS_TOP, f"#define NVAL {len(a_values)}",
                      f"#define OPA_INIT {_farr(a_values)}", f"#define OPB_INIT {_farr(b_values)}", OPS_MAIN])
