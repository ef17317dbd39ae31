fn main() {
    println!("gpecnet: CLI under construction");
}
