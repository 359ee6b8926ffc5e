// Placeholder entry point; replaced by the generator.
int main() { return 0; }
