/* Fleet membership: the datagram MAC and the key file (hal_host_auth.h). */
#include "hal_host_auth.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <openssl/evp.h>
#include <pthread.h>
#include <sodium.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

_Static_assert(HAL_HOST_AUTH_TAG_BYTES == crypto_aead_xchacha20poly1305_ietf_ABYTES, "tag size");
_Static_assert(HAL_HOST_AUTH_NONCE_BYTES == crypto_aead_xchacha20poly1305_ietf_NPUBBYTES, "nonce size");
_Static_assert(crypto_aead_xchacha20poly1305_ietf_KEYBYTES >= crypto_generichash_BYTES_MIN &&
                   crypto_aead_xchacha20poly1305_ietf_KEYBYTES <= crypto_generichash_BYTES_MAX, "channel key size");
_Static_assert(crypto_generichash_KEYBYTES == HAL_HOST_AUTH_KEY_BYTES, "key size");

#define KEY_HEX (2u * HAL_HOST_AUTH_KEY_BYTES)

static int fail(char *why, size_t cap, const char *fmt, ...)
{
    if (why != NULL && cap > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(why, cap, fmt, ap);
        va_end(ap);
    }
    return -1;
}

int hal_host_auth_init(void)
{
    return sodium_init() < 0 ? -EIO : 0; /* 1: done before, fine */
}

int hal_host_auth_key_load(const char *path, uint8_t key[HAL_HOST_AUTH_KEY_BYTES], char *why, size_t why_cap)
{
    if (path == NULL || key == NULL)
        return fail(why, why_cap, "no key file given");
    if (hal_host_auth_init() != 0)
        return fail(why, why_cap, "libsodium cannot start");
    const int fd = open(path, O_RDONLY | O_CLOEXEC | O_NOCTTY);
    if (fd < 0)
        return fail(why, why_cap, "%s: cannot open the key file: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return fail(why, why_cap, "%s: not a regular file", path);
    }
    /* The contents first, the mode after: a file that is no key at all (a README) is "not a fleet
       key", whatever its mode; only a key says "chmod 600". */
    char text[KEY_HEX + 3u]; /* the digits, a newline, one byte more to see what is too long */
    ssize_t n = read(fd, text, sizeof text);
    close(fd);
    if (n < 0)
        return fail(why, why_cap, "%s: cannot read the key file: %s", path, strerror(errno));
    size_t len = (size_t)n;
    if (len > 0 && text[len - 1] == '\n')
        len--;
    size_t used = 0;
    const int bad = len != KEY_HEX ||
                    sodium_hex2bin(key, HAL_HOST_AUTH_KEY_BYTES, text, len, NULL, &used, NULL) != 0 ||
                    used != HAL_HOST_AUTH_KEY_BYTES;
    sodium_memzero(text, sizeof text);
    if (bad) {
        sodium_memzero(key, HAL_HOST_AUTH_KEY_BYTES);
        return fail(why, why_cap, "%s: not a fleet key (%u hexadecimal digits and a newline; "
                                  "`host_sim key new FILE` writes one)", path, KEY_HEX);
    }
    if ((st.st_mode & 077) != 0) {
        sodium_memzero(key, HAL_HOST_AUTH_KEY_BYTES);
        return fail(why, why_cap, "%s: the fleet key is readable by others (mode %04o): chmod 600 %s", path,
                    (unsigned)(st.st_mode & 07777), path);
    }
    return 0;
}

int hal_host_auth_key_new(const char *path, char *why, size_t why_cap)
{
    if (path == NULL || path[0] == '\0')
        return fail(why, why_cap, "no key file given");
    if (hal_host_auth_init() != 0)
        return fail(why, why_cap, "libsodium cannot start");
    uint8_t key[HAL_HOST_AUTH_KEY_BYTES];
    char text[KEY_HEX + 2u];
    crypto_generichash_keygen(key);
    sodium_bin2hex(text, sizeof text, key, sizeof key);
    sodium_memzero(key, sizeof key);
    text[KEY_HEX] = '\n';
    const int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0) {
        sodium_memzero(text, sizeof text);
        return fail(why, why_cap, "%s: cannot create the key file: %s%s", path, strerror(errno),
                    errno == EEXIST ? " (a key is never overwritten: remove it first)" : "");
    }
    const ssize_t w = write(fd, text, KEY_HEX + 1u);
    sodium_memzero(text, sizeof text);
    const int ok = w == (ssize_t)(KEY_HEX + 1u) && fsync(fd) == 0;
    const int err = errno;
    if (close(fd) != 0 || !ok) {
        unlink(path);
        return fail(why, why_cap, "%s: cannot write the key file: %s", path, strerror(ok ? errno : err));
    }
    return 0;
}

static void put_be64(uint8_t *p, uint64_t v)
{
    for (int i = 7; i >= 0; i--, v >>= 8)
        p[i] = (uint8_t)v;
}

static uint64_t get_be64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; i++)
        v = v << 8 | p[i];
    return v;
}

/* The channel's own key: BLAKE2b-256(key; channel | 0x00). A tag made under one channel's
 * key says nothing under another's, so a message cannot move to another channel. */
static void channel_key(const uint8_t *key, const char *channel, uint8_t *out)
{
    (void)crypto_generichash(out, crypto_aead_xchacha20poly1305_ietf_KEYBYTES, (const unsigned char *)channel,
                             strlen(channel) + 1u, key, HAL_HOST_AUTH_KEY_BYTES);
}

/* ---- the tag's bulk through OpenSSL ------------------------------------------------------
 * XChaCha20-Poly1305 is ChaCha20-Poly1305 (IETF) under the subkey HChaCha20(key, nonce[0..16))
 * with the nonce 0^4 | nonce[16..24). libsodium 1.0.18 (Debian 12's) runs Poly1305 in SSE2 at
 * about 4 GB/s on a datagram the kernel has just copied; OpenSSL's AVX2 / AVX-512 IFMA / NEON
 * code gives the same tag at 6.8 GB/s on a Zen 5 core, where a robot of 64 checks about 5 MB a
 * round. Its set-up costs more, so datagrams shorter than AUTH_BULK_BYTES (the crossing point
 * measured there) stay with libsodium, as does any datagram OpenSSL fails on: the tag is the same
 * either way (tests/hal/test_auth.c checks the two against each other). */
#define AUTH_BULK_BYTES 2048u

static pthread_once_t bulk_once = PTHREAD_ONCE_INIT;
static EVP_CIPHER *bulk_aead;   /* NULL: OpenSSL has none; libsodium does everything */
static pthread_key_t bulk_key;  /* each thread's context, freed when the thread ends */

static void bulk_ctx_free(void *ctx)
{
    EVP_CIPHER_CTX_free(ctx);
}

static void bulk_start(void)
{
    /* no key, no cipher: bulk_aead stays NULL and libsodium tags everything */
    if (pthread_key_create(&bulk_key, bulk_ctx_free) == 0)
        bulk_aead = EVP_CIPHER_fetch(NULL, "ChaCha20-Poly1305", NULL);
}

/* This thread's OpenSSL context (made at its first long datagram), or NULL. */
static EVP_CIPHER_CTX *bulk_ctx(void)
{
    if (pthread_once(&bulk_once, bulk_start) != 0 || bulk_aead == NULL)
        return NULL;
    EVP_CIPHER_CTX *c = pthread_getspecific(bulk_key);
    if (c == NULL && (c = EVP_CIPHER_CTX_new()) != NULL && pthread_setspecific(bulk_key, c) != 0) {
        EVP_CIPHER_CTX_free(c);
        c = NULL;
    }
    return c;
}

/* The tag through OpenSSL: 0, or -1 (nothing usable in tag). */
static int bulk_tag(const uint8_t *ck, const uint8_t *ad, size_t len, const uint8_t *nonce, uint8_t *tag)
{
    EVP_CIPHER_CTX *c = bulk_ctx();
    if (c == NULL || len > (size_t)INT_MAX)
        return -1;
    uint8_t sub[crypto_core_hchacha20_OUTPUTBYTES], iv[12] = {0};
    _Static_assert(crypto_core_hchacha20_INPUTBYTES == 16u && HAL_HOST_AUTH_NONCE_BYTES == 16u + 8u, "nonce split");
    (void)crypto_core_hchacha20(sub, nonce, ck, NULL);
    memcpy(iv + 4, nonce + 16, 8);
    int n = 0;
    const int ok = EVP_EncryptInit_ex2(c, bulk_aead, sub, iv, NULL) == 1 &&
                   EVP_EncryptUpdate(c, NULL, &n, ad, (int)len) == 1 && EVP_EncryptFinal_ex(c, NULL, &n) == 1 &&
                   EVP_CIPHER_CTX_ctrl(c, EVP_CTRL_AEAD_GET_TAG, HAL_HOST_AUTH_TAG_BYTES, tag) == 1;
    sodium_memzero(sub, sizeof sub);
    return ok ? 0 : -1;
}

/* tag = XChaCha20-Poly1305 (channel key, nonce) over no plaintext with `signed_part` (the
 * message and the run id, contiguous on the wire) as its associated data. */
static void tag_of(const uint8_t *key, const char *channel, const uint8_t *signed_part, size_t len,
                   const uint8_t *nonce, uint8_t *tag)
{
    uint8_t ck[crypto_aead_xchacha20poly1305_ietf_KEYBYTES];
    channel_key(key, channel, ck);
    if (len < AUTH_BULK_BYTES || bulk_tag(ck, signed_part, len, nonce, tag) != 0) {
        unsigned long long tag_len = 0;
        uint8_t none[1] = {0}; /* the empty ciphertext's place (libsodium wants a pointer) */
        (void)crypto_aead_xchacha20poly1305_ietf_encrypt_detached(none, tag, &tag_len, none, 0, signed_part, len,
                                                                  NULL, nonce, ck);
    }
    sodium_memzero(ck, sizeof ck);
}

void hal_host_auth_seal(const hal_host_auth_t *a, const char *channel, uint8_t *wire, size_t len)
{
    /* The run id continues the message, and the two are signed as one run of bytes. */
    uint8_t *trailer = wire + len;
    put_be64(trailer, a->run_id);
    uint8_t *nonce = trailer + HAL_HOST_AUTH_RUN_ID_BYTES;
    randombytes_buf(nonce, HAL_HOST_AUTH_NONCE_BYTES);
    tag_of(a->key, channel, wire, len + HAL_HOST_AUTH_RUN_ID_BYTES, nonce, nonce + HAL_HOST_AUTH_NONCE_BYTES);
}

hal_host_auth_verdict_t hal_host_auth_open(const hal_host_auth_t *a, const char *channel, const void *wire,
                                           size_t wire_len, size_t *msg_len)
{
    if (wire == NULL || wire_len < HAL_HOST_AUTH_TRAILER_BYTES)
        return HAL_HOST_AUTH_SHORT;
    const size_t len = wire_len - HAL_HOST_AUTH_TRAILER_BYTES;
    const uint8_t *trailer = (const uint8_t *)wire + len;
    const uint8_t *nonce = trailer + HAL_HOST_AUTH_RUN_ID_BYTES;
    /* The tag the datagram should carry, compared in constant time. */
    uint8_t want[HAL_HOST_AUTH_TAG_BYTES];
    _Static_assert(HAL_HOST_AUTH_TAG_BYTES == crypto_verify_16_BYTES, "tag compare");
    tag_of(a->key, channel, wire, len + HAL_HOST_AUTH_RUN_ID_BYTES, nonce, want);
    const int bad = crypto_verify_16(want, nonce + HAL_HOST_AUTH_NONCE_BYTES);
    sodium_memzero(want, sizeof want);
    if (bad != 0)
        return HAL_HOST_AUTH_BAD_TAG;
    /* Only a valid tag makes the run id worth reading: forged bytes say nothing. */
    if (get_be64(trailer) != a->run_id)
        return HAL_HOST_AUTH_OTHER_RUN;
    if (msg_len != NULL)
        *msg_len = len;
    return HAL_HOST_AUTH_OK;
}

void hal_host_auth_wipe(hal_host_auth_t *a)
{
    if (a != NULL)
        sodium_memzero(a, sizeof *a);
}

const char *hal_host_auth_verdict_name(hal_host_auth_verdict_t v)
{
    switch (v) {
    case HAL_HOST_AUTH_OK:
        return "ok";
    case HAL_HOST_AUTH_SHORT:
        return "no trailer";
    case HAL_HOST_AUTH_BAD_TAG:
        return "bad tag";
    case HAL_HOST_AUTH_OTHER_RUN:
        return "another run";
    }
    return "?";
}
