#include <iostream>
int main() { std::cout << "minimanip\n"; return 0; }
