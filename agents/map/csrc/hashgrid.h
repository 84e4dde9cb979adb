/* Constants of the hash-grid encoding, defined once: hashgrid.c uses them and
   ramensim.agents.map.hashgrid reads them from this file (PRIMES), so C and Python agree. */
#ifndef RAMENSIM_HASHGRID_H
#define RAMENSIM_HASHGRID_H
#define P1 2654435761u /* hash prime of y (x's is 1) */
#define P2 805459861u  /* hash prime of z */
#endif
