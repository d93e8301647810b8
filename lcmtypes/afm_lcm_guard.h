/* The guards the bus's C++ message decoders call (tools/guard_lcm_cpp.py
 * rewrites lcm-gen's output to call them; lcmtypes/CMakeLists.txt).
 *
 * LCM's generated decoders trust a message's own length fields: an array
 * length of 2^30 resizes a vector to 2^30 elements (gigabytes, value
 * initialised) before the decode finds the bytes missing, and a string
 * length of 0 or less makes std::string::assign throw (a crash in the
 * callback); a string without its NUL, or with one inside, is refused too. The guarded decoders refuse both before allocating, since every
 * element takes at least one byte on the wire, and refuse a NaN or an
 * infinity in any double or float field: no message of the bus carries one.
 *
 * decode() returns -1 for a short buffer or another type's fingerprint (as
 * LCM does), AFM_LCM_E_LENGTH for a length field past the bytes that are
 * left, AFM_LCM_E_NONFINITE for a non-finite number. afm::decode_checked
 * (bus/inbox.hpp) names the reason. */
#ifndef AFM_LCM_GUARD_H
#define AFM_LCM_GUARD_H

#include <stdint.h>
#include <string.h>
#include <lcm/lcm_coretypes.h>

#define AFM_LCM_E_LENGTH (-2)
#define AFM_LCM_E_NONFINITE (-3)

/* A string field of `len` bytes at `at` (its length field says len,
 * the terminating NUL counted): it must end in its NUL and hold no other,
 * or the decoded string would lose its last byte or re-encode shorter. */
static inline int afm_lcm_string_ok(const void *buf, int at, int len)
{
    const char *s = (const char *)buf + at;
    return s[len - 1] == '\0' && memchr(s, '\0', (size_t)(len - 1)) == NULL;
}

/* Each element through LCM's own 64- and 32-bit decoders, its exponent
 * checked on the bits (all ones: an infinity or a NaN). */
static inline int afm_lcm_decode_finite_double(const void *buf, int offset, int maxlen, double *p, int elements)
{
    if (elements < 0 || maxlen < 0 || maxlen / 8 < elements) return -1;
    for (int i = 0; i < elements; ++i) {
        int64_t bits = 0;
        if (__int64_t_decode_array(buf, offset + 8 * i, maxlen - 8 * i, &bits, 1) < 0) return -1;
        if ((((uint64_t)bits >> 52) & 0x7ffu) == 0x7ffu) return AFM_LCM_E_NONFINITE;
        memcpy(&p[i], &bits, sizeof bits);
    }
    return 8 * elements;
}

static inline int afm_lcm_decode_finite_float(const void *buf, int offset, int maxlen, float *p, int elements)
{
    if (elements < 0 || maxlen < 0 || maxlen / 4 < elements) return -1;
    for (int i = 0; i < elements; ++i) {
        int32_t bits = 0;
        if (__int32_t_decode_array(buf, offset + 4 * i, maxlen - 4 * i, &bits, 1) < 0) return -1;
        if ((((uint32_t)bits >> 23) & 0xffu) == 0xffu) return AFM_LCM_E_NONFINITE;
        memcpy(&p[i], &bits, sizeof bits);
    }
    return 4 * elements;
}

#endif
