fn main() {
    println!("ftpd3d {}", ftpd3d::version_string());
}
