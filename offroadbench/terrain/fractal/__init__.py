"""Fractal surface generators: Weierstrass-Mandelbrot (Majhor & Bos 2023), the multifractal
product, fBm by Fourier filtering (Yoshikawa & Nishiguchi 2017) and diamond-square."""
