fn main() {
    println!("ispm");
}
