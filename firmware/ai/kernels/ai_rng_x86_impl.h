/* The body of one x86-64 Philox lanes kernel (ai_rng_lanes.h), instantiated per instruction
 * set by ai_rng_x86.c: the including file defines RV_FN, RV_W (32-bit lanes per vector), the
 * vector type rv and rv_set1, rv_iota (0, 1, ..), rv_add, rv_xor3 (a ^ b ^ c), rv_carry(c, lo)
 * (1 where c < lo unsigned, else 0), rv_mul_even (the 64-bit products of the even lanes),
 * rv_srl64 / rv_sll64 (by 32 within 64-bit lanes), rv_blend_odd (even lanes of a, odd of b),
 * rv_storeu. Not a public header. */
#define RV_M0 0xD2511F53u
#define RV_M1 0xCD9E8D57u
#define RV_W0 0x9E3779B9u
#define RV_W1 0xBB67AE85u

/* hi and lo words of c * m, lane by lane: the even lanes' products and the odd lanes' (moved
 * down first), put back in their lanes */
static inline void rv_mulhilo(rv c, rv m, rv *hi, rv *lo)
{
    const rv pe = rv_mul_even(c, m), po = rv_mul_even(rv_srl64(c), m);
    *hi = rv_blend_odd(rv_srl64(pe), po);
    *lo = rv_blend_odd(pe, rv_sll64(po));
}

void RV_FN(uint64_t key, uint64_t stream, uint64_t b0, uint32_t nb, uint32_t *l0, uint32_t *l1,
           uint32_t *l2, uint32_t *l3)
{
    const uint32_t k0 = (uint32_t)key, k1 = (uint32_t)(key >> 32);
    const rv m0 = rv_set1(RV_M0), m1 = rv_set1(RV_M1);
    for (uint32_t i = 0; i < nb; i += RV_W) {
        /* counters b0 + i + lane: the low words wrap, the high words take the carry */
        const uint64_t b = b0 + i;
        const rv lo = rv_set1((uint32_t)b);
        rv c0 = rv_add(lo, rv_iota());
        rv c1 = rv_add(rv_set1((uint32_t)(b >> 32)), rv_carry(c0, lo));
        rv c2 = rv_set1((uint32_t)stream), c3 = rv_set1((uint32_t)(stream >> 32));
        uint32_t ka = k0, kb = k1;
        for (int r = 0; r < 10; r++) {
            rv hi0, lo0, hi1, lo1;
            rv_mulhilo(c0, m0, &hi0, &lo0);
            rv_mulhilo(c2, m1, &hi1, &lo1);
            c0 = rv_xor3(hi1, c1, rv_set1(ka));
            c2 = rv_xor3(hi0, c3, rv_set1(kb));
            c1 = lo1;
            c3 = lo0;
            ka += RV_W0;
            kb += RV_W1;
        }
        rv_storeu(l0 + i, c0);
        rv_storeu(l1 + i, c1);
        rv_storeu(l2 + i, c2);
        rv_storeu(l3 + i, c3);
    }
}

#undef RV_M0
#undef RV_M1
#undef RV_W0
#undef RV_W1
