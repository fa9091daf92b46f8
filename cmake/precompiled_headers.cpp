// SPDX-License-Identifier: MIT
// Compiled only to build the precompiled headers (cmake/precompiled_headers.cmake); the
// executable that carries the -fPIE variant needs a main.
int main() { return 0; }
