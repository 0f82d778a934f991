// Drawing a frame in two layers: the surface (the mesh, the parts, the sharp edges) and what
// lies over it (lines, key markers, previews). Dragging a key changes only the overlay, yet a
// frame used to draw the whole mesh again: with software WebGL that is about 0.5 s for 269k
// triangles. The surface is drawn into a texture, with its depth, only when it changes (camera,
// size, colours, materials, what is shown); every frame copies that texture and depth to the
// screen and draws the overlay on it, depth-tested against the surface as before.
import * as THREE from 'three';

// Copies the surface's colour and depth to the screen: depth too, so a line behind a fold is
// still hidden by the surface.
const COPY_VERTEX = /* glsl */ `
varying vec2 vUv;
void main() {
  vUv = uv;
  gl_Position = vec4(position.xy, 0.0, 1.0);
}`;
const COPY_FRAGMENT = /* glsl */ `
uniform sampler2D surfaceColor;
uniform sampler2D surfaceDepth;
varying vec2 vUv;
void main() {
  gl_FragColor = texture2D(surfaceColor, vUv);
  gl_FragDepth = texture2D(surfaceDepth, vUv).x;
}`;

// What the surface's picture depends on, as one string: when it is unchanged, the texture
// still holds the right picture. Attribute and material versions count every change made
// through three.js's needsUpdate, so a change to the surface must set needsUpdate (or add
// new objects, or change visibility) to be seen; the lights and clear colour are fixed.
export function surfaceSignature(groups, camera, width, height) {
  const parts = [width, height, ...camera.matrixWorld.elements, ...camera.projectionMatrix.elements];
  for (const group of groups)
    group.traverse((o) => {
      parts.push(o.id, o.visible ? 1 : 0);
      if (o.matrixWorld) parts.push(...o.matrixWorld.elements);
      const g = o.geometry;
      if (g) {
        parts.push(g.id, g.index?.version ?? -1, g.drawRange.start, g.drawRange.count);
        for (const name in g.attributes) parts.push(name, g.attributes[name].version);
      }
      for (const m of o.material ? [o.material].flat() : []) parts.push(m.id, m.version, m.visible ? 1 : 0);
    });
  return parts.join(',');
}

export class SurfaceLayer {
  // surfaceGroups: the groups drawn into the texture; overlayGroups: the ones drawn on top.
  constructor(renderer, surfaceGroups, overlayGroups) {
    this.renderer = renderer;
    this.surfaceGroups = surfaceGroups;
    this.overlayGroups = overlayGroups;
    this.target = null;
    this.signature = '';
    this.surfaceDraws = 0; // how often the surface was drawn (tests read it)
    this.copyMaterial = new THREE.ShaderMaterial({
      uniforms: { surfaceColor: { value: null }, surfaceDepth: { value: null } },
      vertexShader: COPY_VERTEX,
      fragmentShader: COPY_FRAGMENT,
      depthTest: true,
      depthWrite: true,
      depthFunc: THREE.AlwaysDepth, // depth is written only while the depth test is on
    });
    this.copyScene = new THREE.Scene();
    const quad = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), this.copyMaterial);
    quad.frustumCulled = false;
    this.copyScene.add(quad);
    this.copyCamera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1);
    this.size = new THREE.Vector2();
  }

  // The texture at the drawing buffer's size, multisampled like the canvas, and drawn into as
  // the canvas is: three.js treats a target marked as XR's like the screen (sRGB-encoded
  // output in plain 8-bit storage, the renderer's tone mapping), so multisampled edges are
  // averaged as on the canvas and the copy is a plain copy, without colour conversions (which
  // cost as much as the copy itself with software WebGL).
  targetFor(width, height) {
    if (this.target && this.target.width === width && this.target.height === height) return this.target;
    this.target?.depthTexture?.dispose();
    this.target?.dispose();
    this.target = new THREE.WebGLRenderTarget(width, height, {
      samples: this.renderer.getContext().getContextAttributes().antialias ? 4 : 0,
      colorSpace: THREE.SRGBColorSpace,
      depthTexture: new THREE.DepthTexture(width, height),
    });
    this.target.isXRRenderTarget = true;
    this.target.texture.internalFormat = 'RGBA8'; // the encoded values as they are, like the canvas
    this.copyMaterial.uniforms.surfaceColor.value = this.target.texture;
    this.copyMaterial.uniforms.surfaceDepth.value = this.target.depthTexture;
    this.signature = '';
    return this.target;
  }

  render(scene, camera) {
    const { width, height } = this.renderer.getDrawingBufferSize(this.size);
    const target = this.targetFor(width, height);
    scene.updateMatrixWorld();
    camera.updateMatrixWorld();
    const signature = surfaceSignature(this.surfaceGroups, camera, width, height);
    if (signature !== this.signature) {
      this.drawOnly(this.surfaceGroups, scene, camera, target);
      this.signature = signature;
      this.surfaceDraws++;
    }
    this.renderer.render(this.copyScene, this.copyCamera);
    const autoClear = this.renderer.autoClear;
    this.renderer.autoClear = false;
    this.drawOnly(this.overlayGroups, scene, camera, null);
    this.renderer.autoClear = autoClear;
  }

  // Draws the scene with only `groups` shown (into `target`, or the canvas for null).
  drawOnly(groups, scene, camera, target) {
    const all = [...this.surfaceGroups, ...this.overlayGroups];
    const shown = all.map((g) => g.visible);
    all.forEach((g) => (g.visible = g.visible && groups.includes(g)));
    this.renderer.setRenderTarget(target);
    this.renderer.render(scene, camera);
    this.renderer.setRenderTarget(null);
    all.forEach((g, i) => (g.visible = shown[i]));
  }
}
