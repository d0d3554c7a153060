// placeholder: pm benchmarks being written
int main() { return 0; }
