/* SHA-256 (FIPS 180-4) of bytes: the model file's digest (crank_variables.h) */
#ifndef CRANK_SHA256_H
#define CRANK_SHA256_H

#include <stddef.h>

void sha256(const unsigned char* data, size_t size, unsigned char out[32]);

#endif
