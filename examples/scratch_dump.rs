fn main() {
    let p = std::env::args().nth(1).unwrap();
    let t = tmo::trial::read_trial(std::path::Path::new(&p)).unwrap();
    println!("{:?}", t.meta.parameters);
    println!("frames {} markers {}", t.frames.len(), t.markers.len());
    for e in &t.events {
        if e.topic == "/phase"
            || e.topic == "/fault"
            || e.topic.starts_with("/command")
            || e.topic == "/detector"
        {
            println!("{:.3} {} {}", e.time_s, e.topic, e.data);
        }
    }
    if let (Some(a), Some(b)) = (t.markers.first(), t.markers.last()) {
        println!("markers {:?} .. {:?}", a, b);
    }
}
