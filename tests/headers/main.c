/* SPDX-License-Identifier: MIT */
/* The header units are checked at compile time; running proves they linked. */
int main(void)
{
    return 0;
}
