// A classic script: if the viewer's modules (or three.js) did not load, say so on the page
// instead of leaving it silently empty.
window.addEventListener('load', () => {
  setTimeout(() => {
    if (window.gvdViewer) return;
    const box = document.getElementById('error');
    document.getElementById('error-text').textContent =
        'The viewer could not start: its scripts or three.js did not load (see the browser console). ' +
        'A server built without clients/web/node_modules lacks three.js: run docker/install-deps.sh and rebuild.';
    box.hidden = false;
  }, 1500);
});
